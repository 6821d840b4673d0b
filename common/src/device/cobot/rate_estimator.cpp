#include "device/cobot/rate_estimator.hpp"

#include <cmath>
#include <numbers>

namespace teleop::device::cobot {

RateEstimator::RateEstimator(const RateEstimatorConfig& config) : config_(config) {}

void RateEstimator::Reset(double angle_rad, double rate_per_s) noexcept {
  last_angle_ = angle_rad;
  rate_ = rate_per_s;
  primed_ = true;
}

double RateEstimator::Step(double angle_rad, double period_s) noexcept {
  if (!std::isfinite(angle_rad) || !(period_s > 0.0)) {
    return rate_;
  }
  if (!primed_) {
    Reset(angle_rad);
    return rate_;
  }
  // Angles may be wrapped (steering): difference taken on the circle.
  double diff = angle_rad - last_angle_;
  diff = std::remainder(diff, 2.0 * std::numbers::pi);
  last_angle_ = angle_rad;
  const double raw = diff / period_s;
  if (config_.cutoff_hz <= 0.0) {
    rate_ = raw;
  } else {
    const double alpha = 1.0 - std::exp(-2.0 * std::numbers::pi * config_.cutoff_hz * period_s);
    rate_ += alpha * (raw - rate_);
  }
  return rate_;
}

}  // namespace teleop::device::cobot
