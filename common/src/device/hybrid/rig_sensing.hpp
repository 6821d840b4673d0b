#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace teleop::device::hybrid {

/// The rig's sensors as the controller sees them (§2.1: optical encoders on the active joints; §2.3: the F/T sensor
/// at the end-effector). Seeded and deterministic: the same seed gives the same readings on every run.
///
/// Encoders: the joint angle, counted from where Reset put it, quantized to 2π/counts_per_joint_rev (default 40 000: a
/// 2000-line quadrature encoder on the pulley-1 axis, ×5 pulleys; the paper gives no resolution), the velocity
/// estimated from the quantized angle by a backward difference through a first-order low-pass of velocity_filter_hz
/// (default 200 Hz). The cubic damper and the brake direction use this estimate. counts 0 = exact angle, filter 0 =
/// unfiltered difference.
struct EncoderConfig {
  double counts_per_joint_rev = 40000.0;
  double velocity_filter_hz = 200.0;
  bool exact_velocity = false;  ///< True: the rig's true joint velocity (the ideal sensor of the earlier model).
  void Validate() const;
};

class JointEncoders {
 public:
  explicit JointEncoders(const EncoderConfig& config);
  /// One sample of the true joint angles: updates the quantized angles and the velocity estimate.
  void Sample(const Eigen::Vector2d& joint_rad, const Eigen::Vector2d& true_velocity_rad_per_s,
              double period_s) noexcept;
  const Eigen::Vector2d& joint_rad() const noexcept { return q_; }
  const Eigen::Vector2d& joint_velocity_rad_per_s() const noexcept { return qd_; }
  void Reset(const Eigen::Vector2d& joint_rad) noexcept;

 private:
  EncoderConfig config_;
  Eigen::Vector2d origin_{0.0, 0.0};  ///< Where counting started (Reset): the count there is 0.
  Eigen::Vector2d q_{0.0, 0.0};
  Eigen::Vector2d qd_{0.0, 0.0};
  bool primed_ = false;
};

/// The handle F/T sensor's dynamics: white noise of noise_std_N per axis (default 0.05 N, a typical 6-axis sensor's
/// resolution at this range; the paper gives none) and a first-order bandwidth of bandwidth_hz (default 500 Hz;
/// 0 = none), seeded. Bias and quantization stay in HandleForceSensorConfig (MeasureHandleForce).
struct ForceSensorDynamicsConfig {
  double noise_std_N = 0.05;
  double bandwidth_hz = 500.0;
  std::uint64_t seed = 1;
  void Validate() const;
};

class ForceSensorDynamics {
 public:
  explicit ForceSensorDynamics(const ForceSensorDynamicsConfig& config);
  /// The reading of this period for the given (already biased, quantized) force. Real-time safe.
  [[nodiscard]] Eigen::Vector2d Filter(const Eigen::Vector2d& force_N, double period_s) noexcept;

 private:
  double Gaussian() noexcept;
  ForceSensorDynamicsConfig config_;
  std::uint64_t state_;
  Eigen::Vector2d filtered_{0.0, 0.0};
  bool primed_ = false;
};

}  // namespace teleop::device::hybrid
