#include "device/cobot/bicycle_caster.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::cobot {

void Validate(const BicycleCasterConfig& c) {
  auto positive = [](double v, const char* name) {
    if (!std::isfinite(v) || v <= 0.0) {
      throw Error(std::string("cobot bicycle caster: ") + name + " must be finite and > 0 (got " + std::to_string(v) +
                  ")");
    }
  };
  positive(c.virtual_mass_kg, "virtual_mass_kg");
  positive(c.virtual_inertia_kgm2, "virtual_inertia_kgm2");
  positive(c.speed_floor_m_per_s, "speed_floor_m_per_s");
  positive(c.k2_Nms_per_rad, "k2_Nms_per_rad");
  positive(c.heading_bandwidth_per_s, "heading_bandwidth_per_s");
  if (!std::isfinite(c.rolling_damping_Ns_per_m) || c.rolling_damping_Ns_per_m < 0.0) {
    throw Error("cobot bicycle caster: rolling_damping_Ns_per_m must be >= 0");
  }
  if (!std::isfinite(c.friction_compensation_Nms_per_rad) || c.friction_compensation_Nms_per_rad < 0.0) {
    throw Error("cobot bicycle caster: friction_compensation_Nms_per_rad must be >= 0");
  }
  if (!std::isfinite(c.heading_target_rad)) throw Error("cobot bicycle caster: heading_target_rad must be finite");
  if (!std::isfinite(c.singularity_threshold) || c.singularity_threshold < 0.0 || c.singularity_threshold >= 1.0) {
    throw Error("cobot bicycle caster: singularity_threshold must be in [0, 1)");
  }
}

BicycleCasterOutput BicycleCasterStep(const BicycleCasterConfig& c, const BicycleGeometry& g,
                                      const BicyclePlantState& m, const Vec2& handle_force_N,
                                      double handle_moment_Nm) noexcept {
  BicycleCasterOutput out;
  const Vec2 force = handle_force_N.allFinite() ? handle_force_N : Vec2::Zero();
  const double moment = std::isfinite(handle_moment_Nm) ? handle_moment_Nm : 0.0;
  const double ca = std::cos(m.pose.angle_rad);
  const double sa = std::sin(m.pose.angle_rad);
  const Vec2 handle(ca * g.handle_m.x() - sa * g.handle_m.y(), sa * g.handle_m.x() + ca * g.handle_m.y());
  const Vec2 v(m.twist(0), m.twist(1));
  const double omega = m.twist(2);
  // The free rigid plate the operator should feel, with its wheels' rolling drag.
  Vec2 drag = Vec2::Zero();
  double drag_moment = 0.0;
  for (int i = 0; i < 2; ++i) {
    const Vec2 lever = WheelPosition(g, m.pose, i) - m.pose.position_m;
    const Vec2 heading = UnitAt(m.pose.angle_rad + m.steer_rad[static_cast<std::size_t>(i)]);
    const Vec2 rolling = -c.rolling_damping_Ns_per_m * heading.dot(v + omega * LeftNormal(lever)) * heading;
    drag += rolling;
    drag_moment += Cross(lever, rolling);
  }
  const Vec2 accel = (force + drag) / c.virtual_mass_kg;
  const double w = c.heading_bandwidth_per_s;
  const double angular_accel = c.heading_constraint
                                   ? -w * w * WrapAngle(m.pose.angle_rad - c.heading_target_rad) - 2.0 * w * omega
                                   : (moment + Cross(handle, force) + drag_moment) / c.virtual_inertia_kgm2;
  std::array<double, 2> command{};
  for (std::size_t i = 0; i < 2; ++i) {
    const Vec2 lever = WheelPosition(g, m.pose, static_cast<int>(i)) - m.pose.position_m;
    const Vec2 heading = UnitAt(m.pose.angle_rad + m.steer_rad[i]);
    const Vec2 normal = LeftNormal(heading);
    const double u = heading.dot(v + omega * LeftNormal(lever));
    const Vec2 wheel_accel = accel + angular_accel * LeftNormal(lever) - omega * omega * lever;
    const double world_rate = normal.dot(wheel_accel) / (SignNonZero(u) * std::max(std::abs(u), c.speed_floor_m_per_s));
    command[i] = world_rate - omega;
  }
  out.singularity_measure = SingularityMeasure(g, m.steer_rad[0], m.steer_rad[1]);
  out.near_singularity = out.singularity_measure < c.singularity_threshold;
  if (c.singularity_guard && out.near_singularity) {
    constexpr double kStep_rad = 1e-4;
    const double g0 = (SingularityMeasure(g, m.steer_rad[0] + kStep_rad, m.steer_rad[1]) -
                       SingularityMeasure(g, m.steer_rad[0] - kStep_rad, m.steer_rad[1])) /
                      (2.0 * kStep_rad);
    const double g1 = (SingularityMeasure(g, m.steer_rad[0], m.steer_rad[1] + kStep_rad) -
                       SingularityMeasure(g, m.steer_rad[0], m.steer_rad[1] - kStep_rad)) /
                      (2.0 * kStep_rad);
    const double along = g0 * command[0] + g1 * command[1];
    const double norm2 = g0 * g0 + g1 * g1;
    if (along < 0.0 && norm2 > 1e-12) {
      command[0] -= along / norm2 * g0;
      command[1] -= along / norm2 * g1;
      out.guard_active = true;
    }
  }
  for (std::size_t i = 0; i < 2; ++i) {
    out.commanded_steer_rate_rad_per_s[i] = command[i];
    out.steering_torque_Nm[i] =
        c.k2_Nms_per_rad * (command[i] - m.steer_rate_rad_per_s[i]) + c.friction_compensation_Nms_per_rad * command[i];
  }
  return out;
}

}  // namespace teleop::device::cobot
