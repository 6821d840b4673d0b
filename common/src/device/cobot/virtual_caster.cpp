#include "device/cobot/virtual_caster.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "device/cobot/planar.hpp"
#include "teleop/error.hpp"

namespace teleop::device::cobot {

void Validate(const VirtualCasterConfig& c) {
  if (!std::isfinite(c.k1_per_kg) || c.k1_per_kg <= 0.0) {
    throw Error("cobot caster: k1_per_kg (1/virtual mass) must be > 0 (got " + std::to_string(c.k1_per_kg) + ")");
  }
  if (!std::isfinite(c.k2_Nms_per_rad) || c.k2_Nms_per_rad <= 0.0) {
    throw Error("cobot caster: k2_Nms_per_rad must be > 0 (got " + std::to_string(c.k2_Nms_per_rad) + ")");
  }
  if (!std::isfinite(c.friction_compensation_Nms_per_rad) || c.friction_compensation_Nms_per_rad < 0.0) {
    throw Error("cobot caster: friction_compensation_Nms_per_rad must be >= 0");
  }
  if (!std::isfinite(c.speed_floor_m_per_s) || c.speed_floor_m_per_s <= 0.0) {
    throw Error("cobot caster: speed_floor_m_per_s (epsilon of eq 2) must be > 0 (got " +
                std::to_string(c.speed_floor_m_per_s) + ")");
  }
}

CasterOutput VirtualCasterStep(const VirtualCasterConfig& c, double force_x_N, double force_y_N,
                               double steering_angle_rad, double speed_m_per_s,
                               double steering_rate_rad_per_s) noexcept {
  CasterOutput out;
  const Vec2 force(std::isfinite(force_x_N) ? force_x_N : 0.0, std::isfinite(force_y_N) ? force_y_N : 0.0);
  const double u = std::isfinite(speed_m_per_s) ? speed_m_per_s : 0.0;
  const double omega = std::isfinite(steering_rate_rad_per_s) ? steering_rate_rad_per_s : 0.0;
  out.lateral_force_N = force.dot(LeftNormal(UnitAt(steering_angle_rad)));
  const double denominator = SignNonZero(u) * std::max(std::abs(u), c.speed_floor_m_per_s);
  out.commanded_rate_rad_per_s = c.k1_per_kg * out.lateral_force_N / denominator;
  out.steering_torque_Nm = c.k2_Nms_per_rad * (out.commanded_rate_rad_per_s - omega) +
                           c.friction_compensation_Nms_per_rad * out.commanded_rate_rad_per_s;
  return out;
}

}  // namespace teleop::device::cobot
