#include "device/cobot/constraint_overlay.hpp"

#include <cmath>

namespace teleop::device::cobot {

OverlayArc ComputeOverlay(const ConstraintSample& sample, const Vec2& position_m, double motion_heading_rad) noexcept {
  OverlayArc arc;
  const double distance = -sample.penetration_m;
  if (!(distance > 0.0)) {
    return arc;
  }
  const Vec2 motion = UnitAt(motion_heading_rad);
  const double sin_theta = motion.dot(sample.normal_in);  // > 0: approaching
  if (!(sin_theta > 1e-9)) {
    return arc;
  }
  const Vec2 tangent = motion.dot(sample.tangent) >= 0.0 ? sample.tangent : Vec2(-sample.tangent);
  const double cos_theta = motion.dot(tangent);
  const double one_minus_cos = 1.0 - cos_theta;  // > 0 since sin θ > 0
  arc.radius_m = distance / one_minus_cos;
  // The normal of the motion on the side away from the wall.
  Vec2 turn = LeftNormal(motion);
  if (turn.dot(sample.normal_in) > 0.0) {
    turn = -turn;
  }
  arc.center_m = position_m + arc.radius_m * turn;
  arc.touch_point_m = arc.center_m + arc.radius_m * sample.normal_in;
  arc.valid = std::isfinite(arc.radius_m);
  return arc;
}

}  // namespace teleop::device::cobot
