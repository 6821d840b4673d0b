#include "device/cobot/bicycle_kinematics.hpp"

#include <cmath>

#include "rolling_svd.hpp"

// The one instantiation of the rolling-constraint SVD (rolling_svd.hpp).
template class Eigen::JacobiSVD<Eigen::Matrix<double, 2, 3>>;

namespace teleop::device::cobot {

namespace {

Vec2 PlateWheel(const BicycleGeometry& g, int wheel) noexcept {
  return {wheel == 0 ? -g.half_wheelbase_m : g.half_wheelbase_m, 0.0};
}

Vec2 Rotate(double angle_rad, const Vec2& v) noexcept {
  const double c = std::cos(angle_rad);
  const double s = std::sin(angle_rad);
  return {c * v.x() - s * v.y(), s * v.x() + c * v.y()};
}

}  // namespace

Vec2 WheelPosition(const BicycleGeometry& g, const BicyclePose& pose, int wheel) noexcept {
  return pose.position_m + Rotate(pose.angle_rad, PlateWheel(g, wheel));
}

Eigen::Matrix<double, 2, 3> RollingConstraints(const BicycleGeometry& g, const BicyclePose& pose, double steer0_rad,
                                               double steer1_rad) noexcept {
  Eigen::Matrix<double, 2, 3> c;
  const double steer[2] = {steer0_rad, steer1_rad};
  for (int i = 0; i < 2; ++i) {
    const Vec2 normal = LeftNormal(UnitAt(pose.angle_rad + steer[i]));
    const Vec2 lever = Rotate(pose.angle_rad, PlateWheel(g, i));
    c(i, 0) = normal.x();
    c(i, 1) = normal.y();
    c(i, 2) = Cross(lever, normal);
  }
  return c;
}

double SingularityMeasure(const BicycleGeometry& g, double steer0_rad, double steer1_rad) noexcept {
  Eigen::Matrix<double, 2, 3> c = RollingConstraints(g, BicyclePose{}, steer0_rad, steer1_rad);
  c.col(2) /= g.half_wheelbase_m;
  const Eigen::JacobiSVD<Eigen::Matrix<double, 2, 3>> svd(c);
  const Eigen::Vector2d& sv = svd.singularValues();
  return sv(0) > 0.0 ? sv(1) / sv(0) : 0.0;
}

InstantaneousCentre ComputeInstantaneousCentre(const BicycleGeometry& g, const BicyclePose& pose, double steer0_rad,
                                               double steer1_rad, double singular_below) noexcept {
  InstantaneousCentre icr;
  icr.singularity_measure = SingularityMeasure(g, steer0_rad, steer1_rad);
  const Vec2 w0 = WheelPosition(g, pose, 0);
  const Vec2 w1 = WheelPosition(g, pose, 1);
  const Vec2 h0 = UnitAt(pose.angle_rad + steer0_rad);
  const Vec2 n0 = LeftNormal(h0);
  const Vec2 n1 = LeftNormal(UnitAt(pose.angle_rad + steer1_rad));
  if (icr.singularity_measure < singular_below) {
    icr.kind = InstantaneousCentre::Kind::kSingular;
    return icr;
  }
  const double det = Cross(n0, n1);
  if (std::abs(det) < 1e-9) {
    icr.kind = InstantaneousCentre::Kind::kAtInfinity;
    icr.direction = h0;
    return icr;
  }
  const double s = Cross(w1 - w0, n1) / det;
  icr.kind = InstantaneousCentre::Kind::kPoint;
  icr.point_m = w0 + s * n0;
  return icr;
}

}  // namespace teleop::device::cobot
