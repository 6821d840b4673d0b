#pragma once

#include "device/cobot/constraint.hpp"

namespace teleop::device::cobot {

/// The constraint overlay of Colgate et al. §5 (Fig. 8): the circular arc tangent to the wheel's direction of motion
/// at the wheel and tangent to the constraint. Its radius is r = d/(1 − cos θ), d the distance to the wall and θ
/// the approach angle; when r falls below a minimum the overlay becomes active and the wheel tracks the arc, which
/// starts the turn before contact. For a curved constraint the arc is built against the tangent line at the nearest
/// point (exact for lines and polyline segments, an approximation near circles).
struct OverlayArc {
  bool valid = false;            ///< False when the wheel is not approaching the wall (θ ≤ 0) or is already in it.
  double radius_m = 0.0;         ///< r.
  Vec2 center_m = Vec2::Zero();  ///< On the side of the wheel away from the wall.
  Vec2 touch_point_m = Vec2::Zero();  ///< Where the arc meets the wall's tangent line.
};

/// The overlay arc for a wheel at `position_m` moving along `motion_heading_rad`, against `sample` (of the wall
/// at that position). Real-time safe.
[[nodiscard]] OverlayArc ComputeOverlay(const ConstraintSample& sample, const Vec2& position_m,
                                        double motion_heading_rad) noexcept;

}  // namespace teleop::device::cobot
