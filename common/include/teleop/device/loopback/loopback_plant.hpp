#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "teleop/analysis/zero_order_hold.hpp"
#include "teleop/device/device.hpp"
#include "teleop/device/loopback/operator_script.hpp"
#include "teleop/device/loopback/simulated_environment.hpp"

namespace teleop::device {

/// Mass–damper per DOF (eqs. 5–6), integrated exactly over the zero-order-held force. Paper defaults (§4.1, with
/// caps and finger loop): master m = 0.040 kg, b = 0.41 N·s/m; slave m = 0.036 kg, b = 0.49 N·s/m.
struct LoopbackPlantConfig {
  int dof = 1;
  double mass_kg = 0.040;
  double damping_Ns_per_m = 0.41;
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

}  // namespace teleop::device
