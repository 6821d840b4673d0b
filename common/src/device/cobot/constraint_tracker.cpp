#include "device/cobot/constraint_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::cobot {

void Validate(const ConstraintTrackerConfig& c) {
  auto positive = [](double v, const char* name) {
    if (!std::isfinite(v) || v <= 0.0) {
      throw Error(std::string("cobot tracker: ") + name + " must be > 0 (got " + std::to_string(v) + ")");
    }
  };
  positive(c.lookahead_m, "lookahead_m");
  positive(c.p_gain_scale, "p_gain_scale");
  positive(c.theta_gain_scale, "theta_gain_scale");
  positive(c.max_curvature_per_m, "max_curvature_per_m");
  positive(c.k2_Nms_per_rad, "k2_Nms_per_rad");
  positive(c.integral_limit_m2, "integral_limit_m2");
  if (!std::isfinite(c.friction_compensation_Nms_per_rad) || c.friction_compensation_Nms_per_rad < 0.0) {
    throw Error("cobot tracker: friction_compensation_Nms_per_rad must be >= 0");
  }
  if (!std::isfinite(c.integral_gain_per_m3) || c.integral_gain_per_m3 < 0.0) {
    throw Error("cobot tracker: integral_gain_per_m3 must be >= 0");
  }
}

TrackingErrors ComputeTrackingErrors(const ConstraintSample& sample, double motion_heading_rad) noexcept {
  TrackingErrors e;
  const Vec2 motion = UnitAt(motion_heading_rad);
  // The tangent that points along the motion; turning away from the wall rotates the motion from normal_in back.
  const Vec2 tangent = motion.dot(sample.tangent) >= 0.0 ? sample.tangent : Vec2(-sample.tangent);
  e.penetration_m = sample.penetration_m;
  e.theta_rad = std::atan2(motion.dot(sample.normal_in), motion.dot(tangent));
  // normal_in to the left of the tangent: into the wall is counter-clockwise, so away is clockwise (ω < 0).
  e.away_sign = Cross(tangent, sample.normal_in) > 0.0 ? -1.0 : 1.0;
  return e;
}

TrackingGains ComputeTrackingGains(ConstraintTrackerConfig::GainForm form, double lookahead_m,
                                   double curvature_per_m) noexcept {
  TrackingGains g;
  const double kappa = std::abs(curvature_per_m);
  if (form == ConstraintTrackerConfig::GainForm::kSmallAngle || kappa * lookahead_m < 1e-3) {
    g.p_per_m2 = 2.0 / (lookahead_m * lookahead_m);
    g.theta_per_m = 2.0 / lookahead_m;
    return g;
  }
  const double rho = 1.0 / kappa;
  const double phi = std::min(lookahead_m * kappa, 1.4);
  const double one_minus_cos = 1.0 - std::cos(phi);
  g.p_per_m2 = std::cos(phi) / (rho * rho * one_minus_cos);
  g.theta_per_m = std::sin(phi) / (rho * one_minus_cos);
  return g;
}

ConstraintTracker::ConstraintTracker(const ConstraintTrackerConfig& config) : config_(config) {}

TrackerOutput ConstraintTracker::Step(const ConstraintSample& sample, double steering_angle_rad, double speed_m_per_s,
                                      double steering_rate_rad_per_s, double period_s, double lookahead_m) noexcept {
  TrackerOutput out;
  const double u = std::isfinite(speed_m_per_s) ? speed_m_per_s : 0.0;
  const double omega = std::isfinite(steering_rate_rad_per_s) ? steering_rate_rad_per_s : 0.0;
  const double motion_heading = u >= 0.0 ? steering_angle_rad : steering_angle_rad + 3.14159265358979323846;
  out.errors = ComputeTrackingErrors(sample, motion_heading);
  const double lookahead = lookahead_m > 0.0 ? lookahead_m : config_.lookahead_m;
  const TrackingGains g = ComputeTrackingGains(config_.gain_form, lookahead, sample.curvature_away_per_m);
  const double ds = std::abs(u) * (period_s > 0.0 ? period_s : 0.0);
  if (config_.integral_gain_per_m3 > 0.0) {
    integral_m2_ =
        std::clamp(integral_m2_ + out.errors.penetration_m * ds, -config_.integral_limit_m2, config_.integral_limit_m2);
  }
  const double kappa_tilde = config_.p_gain_scale * g.p_per_m2 * out.errors.penetration_m +
                             config_.theta_gain_scale * g.theta_per_m * out.errors.theta_rad +
                             config_.integral_gain_per_m3 * integral_m2_;
  out.curvature_command_per_m =
      std::clamp(sample.curvature_away_per_m + kappa_tilde, -config_.max_curvature_per_m, config_.max_curvature_per_m);
  // ω turns the direction of motion; for u < 0 the motion is opposite to the heading but turns the same way.
  out.commanded_rate_rad_per_s = out.errors.away_sign * std::abs(u) * out.curvature_command_per_m;
  out.steering_torque_Nm = config_.k2_Nms_per_rad * (out.commanded_rate_rad_per_s - omega) +
                           config_.friction_compensation_Nms_per_rad * out.commanded_rate_rad_per_s;
  return out;
}

}  // namespace teleop::device::cobot
