#include "device/cobot/scripted_operator.hpp"

#include <algorithm>
#include <cmath>

namespace teleop::device::cobot {

Vec2 TurningOperator::Step(const UnicyclePlantState& s, double period_s) noexcept {
  const double speed_error = config_.speed_m_per_s - s.speed_m_per_s;
  speed_integral_N_ = std::clamp(speed_integral_N_ + config_.speed_integral_gain_N_per_m * speed_error * period_s,
                                 -config_.max_force_N, config_.max_force_N);
  const double along = std::clamp(config_.speed_gain_Ns_per_m * speed_error + speed_integral_N_, -config_.max_force_N,
                                  config_.max_force_N);
  const double lateral_accel = s.speed_m_per_s * s.steering_rate_rad_per_s;
  lateral_N_ = std::clamp(lateral_N_ + config_.lateral_integral_gain_Ns_per_m *
                                           (config_.lateral_acceleration_m_per_s2 - lateral_accel) * period_s,
                          -config_.max_force_N, config_.max_force_N);
  const Vec2 heading = UnitAt(s.heading_rad);
  return along * heading + lateral_N_ * LeftNormal(heading);
}

Vec2 PushingOperator::Direction(const Vec2& position_m, const Vec2& motion) const noexcept {
  const ConstraintSample g = guide_.Evaluate(position_m);
  const Vec2 tangent = motion.dot(g.tangent) >= 0.0 ? g.tangent : Vec2(-g.tangent);
  return std::cos(config_.push_angle_rad) * tangent + std::sin(config_.push_angle_rad) * g.normal_in;
}

Vec2 PushingOperator::Step(const UnicyclePlantState& s, double period_s) noexcept {
  const Vec2 motion = UnitAt(s.heading_rad) * SignNonZero(s.speed_m_per_s);
  const Vec2 direction = Direction(s.position_m, motion);
  const double speed = std::abs(s.speed_m_per_s);
  const double speed_error = config_.speed_m_per_s - speed;
  speed_integral_N_ = std::clamp(speed_integral_N_ + config_.speed_integral_gain_N_per_m * speed_error * period_s, 0.0,
                                 config_.max_force_N);
  const double magnitude = std::clamp(config_.speed_gain_Ns_per_m * speed_error + speed_integral_N_,
                                      config_.min_force_N, config_.max_force_N);
  return magnitude * direction;
}

}  // namespace teleop::device::cobot
