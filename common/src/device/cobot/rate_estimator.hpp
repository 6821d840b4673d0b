#pragma once

namespace teleop::device::cobot {

/// Digital differentiation and filtering of an angle (§3.2: "u and ω are estimated by digital differentiation and
/// digital filtering of the associated angular measures"): a backward difference followed by a first-order
/// low-pass of cut-off `cutoff_hz` (discretized exactly for the period). Real-time safe.
struct RateEstimatorConfig {
  double cutoff_hz = 50.0;
};

class RateEstimator {
 public:
  explicit RateEstimator(const RateEstimatorConfig& config = {});
  /// Starts from `angle_rad` at rest (no difference spike on the first sample).
  void Reset(double angle_rad, double rate_per_s = 0.0) noexcept;
  /// New sample; returns the filtered rate (unit of the angle per second).
  double Step(double angle_rad, double period_s) noexcept;
  double rate() const noexcept { return rate_; }

 private:
  RateEstimatorConfig config_;
  double last_angle_ = 0.0;
  double rate_ = 0.0;
  bool primed_ = false;
};

}  // namespace teleop::device::cobot
