#pragma once

#include <Eigen/Core>

namespace teleop::device::hybrid {

/// The force/torque sensor at the end-effector (§2.3): it measures the force the operator's hand applies to the
/// handle, base frame, with a constant bias and a quantisation step (N; 0 = none). A non-finite input stays
/// non-finite so the device reports a sensor fault instead of a plausible number.
struct HandleForceSensorConfig {
  Eigen::Vector2d bias_N{0.0, 0.0};
  double resolution_N = 0.0;
  void Validate() const;  ///< teleop::Error for a non-finite bias or a negative/non-finite resolution.
};

[[nodiscard]] Eigen::Vector2d MeasureHandleForce(const HandleForceSensorConfig& config,
                                                 const Eigen::Vector2d& true_force_N) noexcept;

}  // namespace teleop::device::hybrid
