#include "device/cobot/bicycle_plant.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "rolling_svd.hpp"
#include "teleop/error.hpp"

namespace teleop::device::cobot {

namespace {

double FiniteOr0(double v) noexcept { return std::isfinite(v) ? v : 0.0; }

Vec2 Rotate(double angle_rad, const Vec2& v) noexcept {
  const double c = std::cos(angle_rad);
  const double s = std::sin(angle_rad);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}

Vec2 Lever(const BicycleGeometry& g, const BicyclePose& pose, int wheel) noexcept {
  return WheelPosition(g, pose, wheel) - pose.position_m;
}

}  // namespace

void Validate(const BicyclePlantConfig& c) {
  auto positive = [](double v, const char* name) {
    if (!std::isfinite(v) || v <= 0.0) {
      throw Error(std::string("cobot bicycle: ") + name + " must be finite and > 0 (got " + std::to_string(v) + ")");
    }
  };
  positive(c.geometry.half_wheelbase_m, "half_wheelbase_m");
  positive(c.plate_mass_kg, "plate_mass_kg");
  positive(c.plate_inertia_kgm2, "plate_inertia_kgm2");
  positive(c.steering_inertia_kgm2, "steering_inertia_kgm2");
  positive(c.max_steering_torque_Nm, "max_steering_torque_Nm");
  positive(c.rank_tolerance, "rank_tolerance");
  if (!std::isfinite(c.rolling_damping_Ns_per_m) || c.rolling_damping_Ns_per_m < 0.0 ||
      !std::isfinite(c.steering_damping_Nms_per_rad) || c.steering_damping_Nms_per_rad < 0.0) {
    throw Error("cobot bicycle: damping values must be finite and >= 0");
  }
  if (!c.geometry.handle_m.allFinite()) {
    throw Error("cobot bicycle: handle_m must be finite");
  }
}

int ProjectOntoRolling(const BicyclePlantConfig& c, const BicyclePose& pose, double steer0_rad, double steer1_rad,
                       Twist& twist) noexcept {
  const Eigen::Vector3d sqrt_mass(std::sqrt(c.plate_mass_kg), std::sqrt(c.plate_mass_kg),
                                  std::sqrt(c.plate_inertia_kgm2));
  Eigen::Matrix<double, 2, 3> weighted = RollingConstraints(c.geometry, pose, steer0_rad, steer1_rad);
  for (int j = 0; j < 3; ++j) weighted.col(j) /= sqrt_mass(j);
  const Eigen::JacobiSVD<Eigen::Matrix<double, 2, 3>> svd(weighted, Eigen::ComputeFullV);
  const Eigen::Vector2d& sv = svd.singularValues();
  const Eigen::Matrix3d& v = svd.matrixV();
  int rank = 0;
  Eigen::Vector3d scaled = sqrt_mass.cwiseProduct(twist);
  for (int k = 0; k < 2; ++k) {
    if (sv(k) > c.rank_tolerance * std::max(sv(0), 1e-300)) {
      scaled -= v.col(k) * v.col(k).dot(scaled);
      ++rank;
    }
  }
  twist = scaled.cwiseQuotient(sqrt_mass);
  return rank;
}

Vec2 WheelVelocity(const BicycleGeometry& g, const BicyclePlantState& s, int wheel) noexcept {
  const Vec2 lever = Lever(g, s.pose, wheel);
  return Vec2(s.twist(0), s.twist(1)) + s.twist(2) * LeftNormal(lever);
}

void Step(const BicyclePlantConfig& c, const BicyclePlantInput& in, double dt, BicyclePlantState& s) noexcept {
  for (std::size_t i = 0; i < 2; ++i) {
    const double torque =
        std::clamp(FiniteOr0(in.steering_torque_Nm[i]), -c.max_steering_torque_Nm, c.max_steering_torque_Nm);
    s.steer_rate_rad_per_s[i] = (s.steer_rate_rad_per_s[i] + dt * torque / c.steering_inertia_kgm2) /
                                (1.0 + dt * c.steering_damping_Nms_per_rad / c.steering_inertia_kgm2);
    s.steer_rad[i] = WrapAngle(s.steer_rad[i] + dt * s.steer_rate_rad_per_s[i]);
  }
  const Vec2 force = in.handle_force_N.allFinite() ? in.handle_force_N : Vec2::Zero();
  const Vec2 handle = Rotate(s.pose.angle_rad, c.geometry.handle_m);
  Eigen::Vector3d generalized(force.x(), force.y(), FiniteOr0(in.handle_moment_Nm) + Cross(handle, force));
  for (int i = 0; i < 2; ++i) {
    const Vec2 heading = UnitAt(s.pose.angle_rad + s.steer_rad[static_cast<std::size_t>(i)]);
    const Vec2 rolling = -c.rolling_damping_Ns_per_m * heading.dot(WheelVelocity(c.geometry, s, i)) * heading;
    generalized += Eigen::Vector3d(rolling.x(), rolling.y(), Cross(Lever(c.geometry, s.pose, i), rolling));
  }
  s.twist += dt * generalized.cwiseQuotient(Eigen::Vector3d(c.plate_mass_kg, c.plate_mass_kg, c.plate_inertia_kgm2));
  s.constraint_rank = ProjectOntoRolling(c, s.pose, s.steer_rad[0], s.steer_rad[1], s.twist);
  s.pose.position_m += dt * Vec2(s.twist(0), s.twist(1));
  s.pose.angle_rad = WrapAngle(s.pose.angle_rad + dt * s.twist(2));
}

}  // namespace teleop::device::cobot
