#pragma once

#include <Eigen/Core>
#include <cmath>
#include <numbers>

namespace teleop::device::cobot {

/// Planar vectors of the cobot, world frame W (the floor the wheels roll on): x, y in metres (positions), m/s
/// (velocities) or newtons (forces), as each variable says.
using Vec2 = Eigen::Vector2d;

/// Unit vector at angle `angle_rad` from the world x axis (counter-clockwise positive).
inline Vec2 UnitAt(double angle_rad) noexcept { return {std::cos(angle_rad), std::sin(angle_rad)}; }

/// `v` rotated by +90° (counter-clockwise): the left normal of a direction.
inline Vec2 LeftNormal(const Vec2& v) noexcept { return {-v.y(), v.x()}; }

/// z component of the planar cross product a × b.
inline double Cross(const Vec2& a, const Vec2& b) noexcept { return a.x() * b.y() - a.y() * b.x(); }

/// Angle wrapped into (-π, π].
inline double WrapAngle(double angle_rad) noexcept {
  const double wrapped = std::remainder(angle_rad, 2.0 * std::numbers::pi);
  return wrapped <= -std::numbers::pi ? wrapped + 2.0 * std::numbers::pi : wrapped;
}

/// +1 for x ≥ 0, else -1 (the sign used where zero must pick a side, as in eq 2's sign(u)).
inline double SignNonZero(double x) noexcept { return x >= 0.0 ? 1.0 : -1.0; }

}  // namespace teleop::device::cobot
