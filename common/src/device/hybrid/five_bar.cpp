#include "device/hybrid/five_bar.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {
namespace {

using Vector2 = FiveBar::Vector2;

double Cross(const Vector2& a, const Vector2& b) noexcept { return a.x() * b.y() - a.y() * b.x(); }

/// |sin| of the angle between a and b (0 when either is zero).
double SinBetween(const Vector2& a, const Vector2& b) noexcept {
  const double n = a.norm() * b.norm();
  return n > 0.0 ? std::abs(Cross(a, b)) / n : 0.0;
}

/// Intersection of the circles (c1, r1) and (c2, r2) on the right of the direction c1→c2 (side = +1) or on its
/// left (side = −1). False when they do not meet.
bool CircleIntersection(const Vector2& c1, double r1, const Vector2& c2, double r2, double side,
                        Vector2& out) noexcept {
  const Vector2 e = c2 - c1;
  const double d = e.norm();
  if (!(d > 1e-12) || d > r1 + r2 || d < std::abs(r1 - r2)) {
    return false;
  }
  const double a = (r1 * r1 - r2 * r2 + d * d) / (2.0 * d);
  const double h = std::sqrt(std::max(0.0, r1 * r1 - a * a));
  const Vector2 mid = c1 + a * e / d;
  const Vector2 right{e.y() / d, -e.x() / d};
  out = mid + side * h * right;
  return true;
}

/// θ + 2πk with k chosen so the angle lies in the 2π window centred on [lo, hi].
double WrapInto(double theta, double lo, double hi) noexcept {
  const double centre = 0.5 * (lo + hi);
  return theta - 2.0 * std::numbers::pi * std::round((theta - centre) / (2.0 * std::numbers::pi));
}

void Require(bool ok, const std::string& what) {
  if (!ok) {
    throw Error("hybrid five-bar: " + what);
  }
}

}  // namespace

void FiveBarConfig::Validate() const {
  for (double v : {proximal_1_m, proximal_2_m, distal_1_m, distal_2_m}) {
    Require(std::isfinite(v) && v > 0.0, "link lengths must be finite and > 0 m");
  }
  Require(std::isfinite(base_separation_m) && base_separation_m >= 0.0, "base_separation_m must be finite and >= 0");
  Require(std::isfinite(joint_1_min_rad) && std::isfinite(joint_1_max_rad) && joint_1_min_rad < joint_1_max_rad,
          "joint 1 range must be finite with min < max");
  Require(std::isfinite(joint_2_min_rad) && std::isfinite(joint_2_max_rad) && joint_2_min_rad < joint_2_max_rad,
          "joint 2 range must be finite with min < max");
  Require(joint_1_max_rad - joint_1_min_rad <= 2.0 * std::numbers::pi &&
              joint_2_max_rad - joint_2_min_rad <= 2.0 * std::numbers::pi,
          "a joint range may span at most 360 degrees");
  Require(std::isfinite(workspace_x_min_m) && std::isfinite(workspace_x_max_m) &&
              workspace_x_min_m < workspace_x_max_m && std::isfinite(workspace_y_min_m) &&
              std::isfinite(workspace_y_max_m) && workspace_y_min_m < workspace_y_max_m,
          "workspace rectangle must be finite with min < max on both axes");
}

FiveBar::FiveBar(const FiveBarConfig& config) : config_(config) { config_.Validate(); }

Vector2 FiveBar::Elbow1(double theta_1_rad) const noexcept {
  return Base1() + config_.proximal_1_m * Vector2{std::cos(theta_1_rad), std::sin(theta_1_rad)};
}

Vector2 FiveBar::Elbow2(double theta_2_rad) const noexcept {
  return Base2() + config_.proximal_2_m * Vector2{std::cos(theta_2_rad), std::sin(theta_2_rad)};
}

bool FiveBar::Forward(const Vector2& q_rad, Vector2& p_m) const noexcept {
  if (!q_rad.allFinite()) {
    return false;
  }
  // Handle on the right of elbow1→elbow2: for the default rhombus (θ1 < θ2) that is the point away from the base.
  return CircleIntersection(Elbow1(q_rad.x()), config_.distal_1_m, Elbow2(q_rad.y()), config_.distal_2_m, +1.0, p_m);
}

bool FiveBar::Inverse(const Vector2& p_m, Vector2& q_rad) const noexcept {
  if (!p_m.allFinite()) {
    return false;
  }
  Vector2 a1;
  Vector2 a2;
  if (!CircleIntersection(Base1(), config_.proximal_1_m, p_m, config_.distal_1_m, +1.0, a1) ||
      !CircleIntersection(Base2(), config_.proximal_2_m, p_m, config_.distal_2_m, -1.0, a2)) {
    return false;
  }
  const Vector2 r1 = a1 - Base1();
  const Vector2 r2 = a2 - Base2();
  q_rad.x() = WrapInto(std::atan2(r1.y(), r1.x()), config_.joint_1_min_rad, config_.joint_1_max_rad);
  q_rad.y() = WrapInto(std::atan2(r2.y(), r2.x()), config_.joint_2_min_rad, config_.joint_2_max_rad);
  return true;
}

bool FiveBar::Jacobian(const Vector2& q_rad, Matrix2& jacobian_m_per_rad) const noexcept {
  Vector2 p;
  if (!Forward(q_rad, p)) {
    return false;
  }
  // Loop closure |p − a_i|² = l_i²  ⇒  (p − a_i)ᵀ ṗ = (p − a_i)ᵀ ȧ_i,  ȧ_i = l_i·u'(θ_i)·θ̇_i.
  const Vector2 r1 = p - Elbow1(q_rad.x());
  const Vector2 r2 = p - Elbow2(q_rad.y());
  const Vector2 da1 = config_.proximal_1_m * Vector2{-std::sin(q_rad.x()), std::cos(q_rad.x())};
  const Vector2 da2 = config_.proximal_2_m * Vector2{-std::sin(q_rad.y()), std::cos(q_rad.y())};
  Matrix2 rows;
  rows.row(0) = r1.transpose();
  rows.row(1) = r2.transpose();
  const double det = rows.determinant();
  if (std::abs(det) < 1e-12 * r1.squaredNorm() * r2.squaredNorm() + 1e-18) {
    return false;
  }
  Matrix2 diag = Matrix2::Zero();
  diag(0, 0) = r1.dot(da1);
  diag(1, 1) = r2.dot(da2);
  jacobian_m_per_rad = rows.inverse() * diag;
  return true;
}

SingularityMargin FiveBar::Margin(const Vector2& q_rad) const noexcept {
  SingularityMargin m;
  Vector2 p;
  if (!Forward(q_rad, p)) {
    return m;
  }
  const Vector2 a1 = Elbow1(q_rad.x());
  const Vector2 a2 = Elbow2(q_rad.y());
  m.parallel = SinBetween(p - a1, p - a2);
  m.serial_1 = SinBetween(a1 - Base1(), p - a1);
  m.serial_2 = SinBetween(a2 - Base2(), p - a2);
  m.min = std::min({m.parallel, m.serial_1, m.serial_2});
  return m;
}

bool FiveBar::InJointLimits(const Vector2& q_rad) const noexcept {
  return q_rad.allFinite() && q_rad.x() >= config_.joint_1_min_rad && q_rad.x() <= config_.joint_1_max_rad &&
         q_rad.y() >= config_.joint_2_min_rad && q_rad.y() <= config_.joint_2_max_rad;
}

bool FiveBar::InWorkspace(const Vector2& p_m) const noexcept {
  if (!p_m.allFinite() || p_m.x() < config_.workspace_x_min_m || p_m.x() > config_.workspace_x_max_m ||
      p_m.y() < config_.workspace_y_min_m || p_m.y() > config_.workspace_y_max_m) {
    return false;
  }
  Vector2 q;
  return Inverse(p_m, q) && InJointLimits(q);
}

}  // namespace teleop::device::hybrid
