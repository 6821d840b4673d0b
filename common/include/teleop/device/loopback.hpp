#pragma once

// The `loopback` backend's one public header: the simulated plant of Abbott & Okamura §4.1 (a mass–damper per DOF),
// its scripted operator (master) and environment (slave), and the backend's registration (docs/configuration.md,
// `device.loopback`). Its private headers are in common/src/device/loopback/ (the key table: loopback_keys.hpp).

#include <array>
#include <cstdint>
#include <string>

#include "teleop/analysis/zero_order_hold.hpp"
#include "teleop/device/device.hpp"
#include "teleop/device/device_config.hpp"
#include "teleop/device/device_registry.hpp"

namespace teleop::device {

/// A scripted exogenous operator force F_h*(t) (Abbott & Okamura eq. 1), one segment after another; the force is
/// the sum of the active segments' contributions. All along one direction per segment.
///
/// A segment is active for t in [start_s, start_s + duration_s); duration_s = 0 means "until the end of the run"
/// (allowed for hold, step and sine; a ramp needs a duration > 0). Contributions while active:
///   hold:  the total force on the segment's axis just before start_s (the segments listed before it), kept;
///   step:  to_N;
///   ramp:  from_N + (to_N - from_N)·(t - start_s)/duration_s;
///   sine:  offset_N + amplitude_N·sin(2π·frequency_hz·(t - start_s)).
/// Example, "ramp 0→3 N over [0.5, 2) s, hold, ramp back to -1 N over [3, 4) s, hold": ramp{0.5, 1.5, 0, 3},
/// hold{2.0, 1.0}, ramp{3.0, 1.0, 3, -1}, hold{4.0, 0}.
/// The plant samples F_h* at the start of each period and holds it over the period (as the paper's model does).
struct OperatorSegment {
  enum class Kind : std::uint8_t { kHold, kStep, kRamp, kSine };
  Kind kind = Kind::kHold;
  double start_s = 0.0;
  double duration_s = 0.0;    ///< Segment is active for t in [start, start+duration); 0 = open-ended.
  double from_N = 0.0;        ///< Ramp start level.
  double to_N = 0.0;          ///< Step level or ramp end level.
  double amplitude_N = 0.0;   ///< Sine amplitude.
  double frequency_hz = 0.0;  ///< Sine frequency.
  double offset_N = 0.0;      ///< Sine offset.
  int axis = 0;               ///< Which DOF the segment drives.
};

/// The simulated operator on the master: an equilibrium-point mass–spring–damper (eqs. 1–2),
/// F_h = F_h*(t) - (m_h·ẍ + b_h·ẋ + k_h·x), rigidly attached to the handle (its mass adds to the device's).
/// The same m_h, b_h, k_h act on every DOF; x is measured from the plant's origin (the operator's rest point).
struct SimulatedOperatorConfig {
  bool enabled = false;
  double mass_kg = 0.0;
  double damping_Ns_per_m = 0.0;
  double stiffness_N_per_m = 0.0;
  static constexpr int kMaxSegments = 16;
  int segment_count = 0;
  std::array<OperatorSegment, kMaxSegments> segments{};
};

/// The script of a SimulatedOperatorConfig, evaluated: F_h*(t) per axis. Hold levels are computed once at
/// construction, so TargetForce is a short loop with no allocation.
class OperatorScript {
 public:
  /// No operator: F_h* = 0.
  OperatorScript() = default;
  /// Validates the operator (when enabled) for `dof`; throws teleop::Error "loopback plant: human.…" naming the field.
  OperatorScript(const SimulatedOperatorConfig& config, int dof);

  /// base_N + F_h*(time_s) on `axis` (N): the active segments' contributions added to base_N in script order.
  /// base_N alone when the operator is disabled.
  double TargetForce(int axis, double time_s, double base_N = 0.0) const noexcept;

 private:
  SimulatedOperatorConfig config_{};
  std::array<double, SimulatedOperatorConfig::kMaxSegments> hold_level_N_{};
};

/// The simulated environment on the slave: free space, or a wall x ≥ position_m on one axis with stiffness and
/// damping (a spring–damper that only pushes).
///
/// Sign (docs/frames.md): the wall's force ON the device is -max(0, k·(x - p) + b·ẋ) along the axis while x > p,
/// else 0. The force sensor reports the reaction, F_e of eq. 4, the force the slave exerts ON the environment:
/// F_e = +max(0, k·(x - p) + b·ẋ) ≥ 0 (positive when the slave pushes along +x).
struct SimulatedEnvironmentConfig {
  enum class Kind : std::uint8_t { kFreeSpace, kWall };
  Kind kind = Kind::kFreeSpace;
  int axis = 0;
  double position_m = 0.0;  ///< Wall surface along `axis`; the wall occupies x > position_m.
  double stiffness_N_per_m = 0.0;
  double damping_Ns_per_m = 0.0;
};

/// A SimulatedEnvironmentConfig, validated, with the wall's contact law.
class SimulatedEnvironment {
 public:
  /// Free space.
  SimulatedEnvironment() = default;
  /// Validates for `dof`; throws teleop::Error "loopback plant: environment.…" naming the field.
  SimulatedEnvironment(const SimulatedEnvironmentConfig& config, int dof);

  /// True when the wall acts on `axis`.
  bool OnAxis(int axis) const noexcept {
    return config_.kind == SimulatedEnvironmentConfig::Kind::kWall && config_.axis == axis;
  }
  /// The magnitude the wall pushes back with at (x, ẋ) on its axis, max(0, k·(x - p) + b·ẋ) inside, 0 outside (N).
  /// This is F_e.
  double Push_N(double position_m, double velocity_m_per_s) const noexcept;
  const SimulatedEnvironmentConfig& config() const noexcept { return config_; }

 private:
  SimulatedEnvironmentConfig config_{};
};

/// Mass–damper per DOF (eqs. 5–6), integrated exactly over the zero-order-held force. Paper defaults (§4.1, with
/// caps and finger loop): master m = 0.040 kg, b = 0.41 N·s/m; slave m = 0.036 kg, b = 0.49 N·s/m.
/// Each default is written here once: the key table (common/src/device/loopback/loopback_keys.hpp) takes those of the
/// keys it lists from a default-constructed struct.
struct LoopbackPlantConfig {
  int dof = 1;
  double mass_kg = 0.040;                    ///< The paper's master (PaperMaster); `mass_kg` is required in YAML.
  double damping_Ns_per_m = 0.41;            ///< The paper's master; required in YAML.
  double encoder_resolution_m = 0.0;         ///< 0: no quantization; else position reads are rounded to this step.
  DofVector initial_position_m;              ///< Empty = zero.
  DofVector initial_velocity_m_per_s;        ///< Empty = zero.
  SimulatedOperatorConfig human{};           ///< Master side.
  SimulatedEnvironmentConfig environment{};  ///< Slave side.
  double force_sensor_noise_N = 0.0;         ///< Reserved; must be 0 (no noise model yet).
  int contact_substeps = 50;                 ///< Sub-steps per period while the wall may be in contact (1..10000).

  /// The paper's master (m = 0.040 kg, b = 0.41 N·s/m) and slave (m = 0.036 kg, b = 0.49 N·s/m), §4.1.
  static LoopbackPlantConfig PaperMaster(int dof = 1);
  static LoopbackPlantConfig PaperSlave(int dof = 1);
};

/// The `loopback` backend: a simulated device + operator (master) or + environment (slave). Reports the operator's
/// interaction force F_h (master, when the operator is enabled) or the environment force F_e (otherwise) as its
/// force sensor; renders every command exactly (Reading::rendered_force_N is the held command). Time is
/// simulated time: Update(period_s) advances it by exactly period_s, so runs are deterministic.
///
/// Integration: per DOF the state (x, ẋ) obeys (m + m_h)·ẍ + (b + b_h)·ẋ + k_h·x = F_h*(t) + command + disturbance
/// (+ wall force on the wall axis). Over one period with the force held, the step is the exact zero-order-hold
/// discretisation exp(A·T) of that linear system (analysis::DiscretizeMassSpringDamper, the one the stability
/// analysis uses; computed once per distinct period and cached). While the wall
/// may be in contact during the period (the state starts inside, or a free step would end inside) the period is
/// split into `contact_substeps` exact sub-steps, each in the contact or the free mode chosen at its start.
///
/// Bad input never reaches the state: a command force of the wrong size or with NaN/inf is replaced by zero force
/// and reported as kFaultDriver in the next Reading (counted by rejected_commands()); an Update with a period that
/// is not finite and > 0 does nothing and is reported the same way (rejected_updates()). The fixture constraints of
/// a Command are not used: the fixture force is already part of Command::force_N.
class LoopbackPlant final : public Device {
 public:
  /// Validates the config; throws teleop::Error naming the bad field.
  explicit LoopbackPlant(const LoopbackPlantConfig& config);

  const Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override { return name_; }
  void Read(Reading& out) noexcept override;
  void Write(const Command& command) noexcept override;
  void Update(double period_s) noexcept override;
  void SetSafe() noexcept override;

  /// True state (not quantized) for tests and telemetry.
  const DofVector& true_position_m() const noexcept { return position_m_; }
  const DofVector& true_velocity_m_per_s() const noexcept { return velocity_m_per_s_; }
  double time_s() const noexcept { return time_s_; }
  /// The operator's exogenous force F_h*(t) at the current time (N), per DOF.
  DofVector OperatorTargetForce() const noexcept;
  /// Extra external force (N) applied in addition to operator/environment, for disturbance tests. A vector of the
  /// wrong size or with NaN/inf is ignored (the disturbance becomes zero).
  void SetDisturbance(const DofVector& force_N) noexcept;
  /// What the force sensor reads now (N): F_h with the operator enabled, else F_e.
  DofVector SensedForce() const noexcept;
  /// The simulated operator presses (true) or releases the clutch pedal; Read reports it (Reading::clutch_pressed).
  void SetClutch(bool pressed) noexcept { clutch_pressed_ = pressed; }
  /// The command currently held (N), after the plant's own checks.
  const DofVector& held_command_N() const noexcept { return command_N_; }
  const LoopbackPlantConfig& config() const noexcept { return config_; }
  std::uint64_t rejected_commands() const noexcept { return rejected_commands_; }
  std::uint64_t rejected_updates() const noexcept { return rejected_updates_; }

 private:
  void CacheSteps(double period_s) noexcept;
  double ExternalForce(int axis, double time_s) const noexcept;  // F_h* + disturbance on one axis

  LoopbackPlantConfig config_;
  Capabilities capabilities_{};
  std::string name_ = "loopback";
  DofVector position_m_;
  DofVector velocity_m_per_s_;
  DofVector command_N_;
  DofVector disturbance_N_;
  double time_s_ = 0.0;
  bool clutch_pressed_ = false;

  double total_mass_kg_ = 0.0;
  double total_damping_Ns_per_m_ = 0.0;
  double total_stiffness_N_per_m_ = 0.0;
  OperatorScript script_{};
  SimulatedEnvironment environment_{};
  double cached_period_s_ = 0.0;
  analysis::ZohBlock free_period_{};
  analysis::ZohBlock free_substep_{};
  analysis::ZohBlock contact_substep_{};
  std::uint32_t pending_faults_ = kFaultNone;
  std::uint64_t rejected_commands_ = 0;
  std::uint64_t rejected_updates_ = 0;
};

/// The `loopback` backend's registration (registered from loopback_backend.cpp): reader of `device.loopback`
/// (a LoopbackPlantConfig), factory (LoopbackPlant) and model (the plant's mass and damping on every axis).
DeviceBackend LoopbackBackend();

/// A DeviceConfig selecting the loopback backend with `plant` (its dof is the config's).
DeviceConfig LoopbackDeviceConfig(const LoopbackPlantConfig& plant);

}  // namespace teleop::device
