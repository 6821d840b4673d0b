#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "device/cobot/planar.hpp"

namespace teleop::device::cobot {

/// The bicycle cobot of Colgate et al. §2 (Fig. 3): two independently steered wheels a fixed distance apart on a
/// rigid plate. The plate frame P has its origin at the midpoint between the wheels and its x axis through them;
/// the plate pose in the world is (x, y, θ). Wheel i's rolling direction in the world is θ + β_i.
struct BicycleGeometry {
  double half_wheelbase_m = 0.2;  ///< Wheels at (±half_wheelbase_m, 0) in the plate frame.
  Vec2 handle_m = Vec2::Zero();   ///< Where the operator holds the plate (plate frame; any point, Fig. 3).
};

struct BicyclePose {
  Vec2 position_m = Vec2::Zero();  ///< Plate origin (m, world).
  double angle_rad = 0.0;          ///< θ.
};

/// Plate twist (world): linear velocity of the plate origin and angular velocity.
using Twist = Eigen::Vector3d;  ///< (v_x m/s, v_y m/s, Ω rad/s).

/// Wheel i's contact point (m, world), i = 0 (at −half_wheelbase) or 1.
[[nodiscard]] Vec2 WheelPosition(const BicycleGeometry& g, const BicyclePose& pose, int wheel) noexcept;

/// The rolling constraints: row i says the velocity of wheel i's contact point has no component along the wheel's
/// left normal n_i: n_i·v + (r_i × n_i)·Ω = 0, r_i from the plate origin to the wheel (world).
[[nodiscard]] Eigen::Matrix<double, 2, 3> RollingConstraints(const BicycleGeometry& g, const BicyclePose& pose,
                                                             double steer0_rad, double steer1_rad) noexcept;

/// Distance from the singularity, dimensionless in [0, 1]: σ_min/σ_max of the rolling constraints with the
/// rotation column scaled by the half wheelbase. 0 exactly when both wheels are aimed perpendicular to the line
/// through them: the centre of rotation would lie on that line, both constraints coincide and the plate gains a
/// degree of freedom (translation across the line and rotation about any point on it).
[[nodiscard]] double SingularityMeasure(const BicycleGeometry& g, double steer0_rad, double steer1_rad) noexcept;

/// The instantaneous centre of rotation: where the two wheels' normal lines meet.
struct InstantaneousCentre {
  enum class Kind : std::uint8_t { kPoint, kAtInfinity, kSingular };
  Kind kind = Kind::kPoint;
  Vec2 point_m = Vec2::Zero();       ///< kPoint: the centre (world).
  Vec2 direction = Vec2::UnitX();    ///< kAtInfinity: the direction of pure translation (world, unit).
  double singularity_measure = 1.0;  ///< SingularityMeasure() of the configuration.
};

/// `singular_below`: measures below it are reported as kSingular. Real-time safe.
[[nodiscard]] InstantaneousCentre ComputeInstantaneousCentre(const BicycleGeometry& g, const BicyclePose& pose,
                                                             double steer0_rad, double steer1_rad,
                                                             double singular_below = 1e-6) noexcept;

}  // namespace teleop::device::cobot
