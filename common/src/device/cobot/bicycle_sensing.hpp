#pragma once

#include <array>

#include "device/cobot/bicycle_plant.hpp"
#include "device/cobot/cobot_sensors.hpp"
#include "device/cobot/rate_estimator.hpp"

namespace teleop::device::cobot {

/// What the bicycle's controllers see (§3.2's sensing, as the unicycle's): the plate position through the position
/// sensing (`position_resolution_m`), each wheel's steering angle through its steering encoder and its rolling
/// through its wheel encoder (counts per revolution, 0 = ideal). The rates are estimated as the paper's prototype
/// does, "by digital differentiation and digital filtering of the associated angular measures" (RateEstimator):
/// each wheel's rolling speed û_i = R·(wheel angle)˙ and steering rate β̂˙_i. The plate's twist follows from the two
/// wheels: a rolling wheel's contact point moves at û_i along its heading t_i (no velocity along its normal), and two
/// points fix a rigid body's planar twist, v = (v₀ + v₁)/2 at the plate origin midway between them and
/// Ω = (v₁ − v₀)·(−sin θ, cos θ)/(2·half_wheelbase), at the singular configuration too. θ is taken as it is (not
/// quantized). Real-time safe.
class BicycleSensing {
 public:
  BicycleSensing(const CobotSensorConfig& sensors, const RateEstimatorConfig& wheel_speed_filter,
                 const RateEstimatorConfig& steering_rate_filter, const BicycleGeometry& geometry);
  /// Starts the encoders at `state`; the next Measure starts the estimators there, at `state`'s rates.
  void Reset(const BicyclePlantState& state) noexcept;
  /// The cycle's measurement of `state`: pose, steering angles and rates, twist as the controllers see them.
  [[nodiscard]] BicyclePlantState Measure(const BicyclePlantState& state, double period_s) noexcept;
  /// Moves the wheel encoders on by the wheels' rolling over the step that led to `state`.
  void Roll(const BicyclePlantState& state, double period_s) noexcept;
  /// Each wheel's rolling speed (m/s) in `state`: its contact point's velocity along its heading.
  [[nodiscard]] std::array<double, 2> RollingSpeeds_m_per_s(const BicyclePlantState& state) const noexcept;

 private:
  CobotSensorConfig sensors_;
  BicycleGeometry geometry_;
  std::array<double, 2> wheel_angle_rad_{0.0, 0.0};  ///< The wheels' true rotation since Reset.
  std::array<RateEstimator, 2> wheel_rate_;
  std::array<RateEstimator, 2> steer_rate_;
  std::array<double, 2> initial_wheel_rate_{0.0, 0.0};  ///< rad/s, from Reset's state.
  std::array<double, 2> initial_steer_rate_{0.0, 0.0};
  bool primed_ = false;  ///< False until the first Measure after Reset.
};

}  // namespace teleop::device::cobot
