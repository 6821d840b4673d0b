#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "teleop/device/device.hpp"

namespace teleop::device {

/// A scripted exogenous operator force F_h*(t) (Abbott & Okamura eq. 1), one segment after another; the force is
/// the sum of the active segments' contributions. All along one direction per segment.
struct OperatorSegment {
  enum class Kind : std::uint8_t { kHold, kStep, kRamp, kSine };
  Kind kind = Kind::kHold;
  double start_s = 0.0;
  double duration_s = 0.0;        ///< Segment is active for t in [start, start+duration); hold keeps the last value.
  double from_N = 0.0;            ///< Ramp start level.
  double to_N = 0.0;              ///< Step level or ramp end level.
  double amplitude_N = 0.0;       ///< Sine amplitude.
  double frequency_hz = 0.0;      ///< Sine frequency.
  double offset_N = 0.0;          ///< Sine offset.
  int axis = 0;                   ///< Which DOF the segment drives.
};

/// The simulated operator on the master: an equilibrium-point mass–spring–damper (eqs. 1–2),
/// F_h = F_h*(t) - (m_h·ẍ + b_h·ẋ + k_h·x), rigidly attached to the handle (its mass adds to the device's).
struct SimulatedOperatorConfig {
  bool enabled = false;
  double mass_kg = 0.0;
  double damping_Ns_per_m = 0.0;
  double stiffness_N_per_m = 0.0;
  static constexpr int kMaxSegments = 16;
  int segment_count = 0;
  std::array<OperatorSegment, kMaxSegments> segments{};
};

/// The simulated environment on the slave: free space, or a wall x·n ≥ position_m on one axis with
/// stiffness and damping (a spring–damper that only pushes).
struct SimulatedEnvironmentConfig {
  enum class Kind : std::uint8_t { kFreeSpace, kWall };
  Kind kind = Kind::kFreeSpace;
  int axis = 0;
  double position_m = 0.0;           ///< Wall surface along `axis`; the wall occupies x > position_m.
  double stiffness_N_per_m = 0.0;
  double damping_Ns_per_m = 0.0;
};

/// Mass–damper per DOF (eqs. 5–6), integrated exactly over the zero-order-held force. Paper defaults (§4.1, with
/// caps and finger loop): master m = 0.040 kg, b = 0.41 N·s/m; slave m = 0.036 kg, b = 0.49 N·s/m.
struct LoopbackPlantConfig {
  int dof = 1;
  double mass_kg = 0.040;
  double damping_Ns_per_m = 0.41;
  double encoder_resolution_m = 0.0;  ///< 0: no quantization; else position reads are rounded to this step.
  DofVector initial_position_m;       ///< Empty = zero.
  SimulatedOperatorConfig human{};    ///< Master side.
  SimulatedEnvironmentConfig environment{};  ///< Slave side.
  double force_sensor_noise_N = 0.0;  ///< Reserved; 0.
};

/// Simulated device + operator (master) or + environment (slave). Reports the operator's interaction force F_h
/// (master) or the environment force F_e (slave) as its force sensor. Time is simulated time: Update(period_s)
/// advances it by exactly period_s, so runs are deterministic.
class LoopbackPlant final : public Device {
 public:
  explicit LoopbackPlant(const LoopbackPlantConfig& config);

  const Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override { return name_; }
  void Read(Reading& out) noexcept override;
  void Write(const DofVector& command_N) noexcept override;
  void Update(double period_s) noexcept override;
  void SetSafe() noexcept override;

  /// True state (not quantized) for tests and telemetry.
  const DofVector& true_position_m() const noexcept { return position_m_; }
  const DofVector& true_velocity_m_per_s() const noexcept { return velocity_m_per_s_; }
  double time_s() const noexcept { return time_s_; }
  /// The operator's exogenous force F_h*(t) at the current time (N), per DOF.
  DofVector OperatorTargetForce() const noexcept;
  /// Extra external force (N) applied in addition to operator/environment, for disturbance tests.
  void SetDisturbance(const DofVector& force_N) noexcept { disturbance_N_ = force_N; }

 private:
  LoopbackPlantConfig config_;
  Capabilities capabilities_{};
  std::string name_ = "loopback";
  DofVector position_m_;
  DofVector velocity_m_per_s_;
  DofVector command_N_;
  DofVector disturbance_N_;
  DofVector sensed_force_N_;
  double time_s_ = 0.0;
};

}  // namespace teleop::device
