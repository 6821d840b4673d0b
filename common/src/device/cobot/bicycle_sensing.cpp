#include "device/cobot/bicycle_sensing.hpp"

#include <cmath>
#include <numbers>

namespace teleop::device::cobot {

namespace {
double EncoderStep(int counts_per_rev) noexcept {
  return counts_per_rev > 0 ? 2.0 * std::numbers::pi / counts_per_rev : 0.0;
}
}  // namespace

BicycleSensing::BicycleSensing(const CobotSensorConfig& sensors, const RateEstimatorConfig& wheel_speed_filter,
                               const RateEstimatorConfig& steering_rate_filter, const BicycleGeometry& geometry)
    : sensors_(sensors),
      geometry_(geometry),
      wheel_rate_{RateEstimator(wheel_speed_filter), RateEstimator(wheel_speed_filter)},
      steer_rate_{RateEstimator(steering_rate_filter), RateEstimator(steering_rate_filter)} {
  Validate(sensors_);
}

std::array<double, 2> BicycleSensing::RollingSpeeds_m_per_s(const BicyclePlantState& s) const noexcept {
  std::array<double, 2> u{0.0, 0.0};
  const Vec2 v(s.twist(0), s.twist(1));
  for (int i = 0; i < 2; ++i) {
    const auto w = static_cast<std::size_t>(i);
    const Vec2 r = WheelPosition(geometry_, s.pose, i) - s.pose.position_m;
    const Vec2 contact = v + s.twist(2) * Vec2(-r.y(), r.x());
    u[w] = contact.dot(UnitAt(s.pose.angle_rad + s.steer_rad[w]));
  }
  return u;
}

void BicycleSensing::Reset(const BicyclePlantState& s) noexcept {
  const std::array<double, 2> u = RollingSpeeds_m_per_s(s);
  for (std::size_t i = 0; i < 2; ++i) {
    wheel_angle_rad_[i] = 0.0;
    initial_wheel_rate_[i] = u[i] / sensors_.wheel_radius_m;
    initial_steer_rate_[i] = s.steer_rate_rad_per_s[i];
  }
  primed_ = false;
}

BicyclePlantState BicycleSensing::Measure(const BicyclePlantState& s, double period_s) noexcept {
  BicyclePlantState m = s;
  m.pose.position_m = {Quantize(s.pose.position_m.x(), sensors_.position_resolution_m),
                       Quantize(s.pose.position_m.y(), sensors_.position_resolution_m)};
  std::array<Vec2, 2> contact{Vec2::Zero(), Vec2::Zero()};
  for (std::size_t i = 0; i < 2; ++i) {
    m.steer_rad[i] = Quantize(s.steer_rad[i], EncoderStep(sensors_.steering_encoder_counts_per_rev));
    const double wheel = Quantize(wheel_angle_rad_[i], EncoderStep(sensors_.wheel_encoder_counts_per_rev));
    if (!primed_) {  // the first sample after Reset starts the differences (no spike) at the initial rates
      steer_rate_[i].Reset(m.steer_rad[i], initial_steer_rate_[i]);
      wheel_rate_[i].Reset(wheel, initial_wheel_rate_[i]);
      m.steer_rate_rad_per_s[i] = steer_rate_[i].rate();
    } else {
      m.steer_rate_rad_per_s[i] = steer_rate_[i].Step(m.steer_rad[i], period_s);
      (void)wheel_rate_[i].Step(wheel, period_s);
    }
    const double u = wheel_rate_[i].rate() * sensors_.wheel_radius_m;
    contact[i] = u * UnitAt(m.pose.angle_rad + m.steer_rad[i]);
  }
  primed_ = true;
  const Vec2 v = 0.5 * (contact[0] + contact[1]);
  const double omega =
      (contact[1] - contact[0]).dot(LeftNormal(UnitAt(m.pose.angle_rad))) / (2.0 * geometry_.half_wheelbase_m);
  m.twist << v.x(), v.y(), omega;
  return m;
}

void BicycleSensing::Roll(const BicyclePlantState& s, double period_s) noexcept {
  const std::array<double, 2> u = RollingSpeeds_m_per_s(s);
  for (std::size_t i = 0; i < 2; ++i) {
    const double next = wheel_angle_rad_[i] + u[i] * period_s / sensors_.wheel_radius_m;
    if (std::isfinite(next)) wheel_angle_rad_[i] = next;
  }
}

}  // namespace teleop::device::cobot
