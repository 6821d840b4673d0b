#include "device/cobot/cobot_sensors.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::cobot {

void Validate(const CobotSensorConfig& c) {
  if (!std::isfinite(c.wheel_radius_m) || c.wheel_radius_m <= 0.0) {
    throw Error("cobot sensors: wheel_radius_m must be > 0 (got " + std::to_string(c.wheel_radius_m) + ")");
  }
  if (c.wheel_encoder_counts_per_rev < 0 || c.steering_encoder_counts_per_rev < 0) {
    throw Error("cobot sensors: encoder counts per revolution must be >= 0 (0 = ideal)");
  }
  if (!std::isfinite(c.position_resolution_m) || c.position_resolution_m < 0.0 ||
      !std::isfinite(c.force_resolution_N) || c.force_resolution_N < 0.0) {
    throw Error("cobot sensors: position_resolution_m and force_resolution_N must be >= 0 (0 = ideal)");
  }
}

double Quantize(double value, double step) noexcept { return step > 0.0 ? std::round(value / step) * step : value; }

CobotMeasurement Measure(const CobotSensorConfig& c, const Vec2& position_m, double heading_rad, double wheel_travel_m,
                         const Vec2& handle_force_N) noexcept {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  CobotMeasurement m;
  m.position_m = {Quantize(position_m.x(), c.position_resolution_m), Quantize(position_m.y(), c.position_resolution_m)};
  const double steer_step = c.steering_encoder_counts_per_rev > 0 ? kTwoPi / c.steering_encoder_counts_per_rev : 0.0;
  m.steering_angle_rad = Quantize(heading_rad, steer_step);
  const double wheel_step = c.wheel_encoder_counts_per_rev > 0 ? kTwoPi / c.wheel_encoder_counts_per_rev : 0.0;
  m.wheel_angle_rad = Quantize(wheel_travel_m / c.wheel_radius_m, wheel_step);
  m.handle_force_N = {Quantize(handle_force_N.x(), c.force_resolution_N),
                      Quantize(handle_force_N.y(), c.force_resolution_N)};
  return m;
}

}  // namespace teleop::device::cobot
