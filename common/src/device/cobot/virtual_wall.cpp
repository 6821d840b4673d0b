#include "device/cobot/virtual_wall.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::cobot {

const char* ToString(WallMode mode) noexcept {
  switch (mode) {
    case WallMode::kCaster:
      return "caster";
    case WallMode::kOverlay:
      return "overlay";
    case WallMode::kTracking:
      return "tracking";
  }
  return "?";
}

void Validate(const VirtualWallConfig& c) {
  Validate(c.caster);
  Validate(c.tracker);
  auto non_negative = [](double v, const char* name) {
    if (!std::isfinite(v) || v < 0.0) {
      throw Error(std::string("cobot wall: ") + name + " must be finite and >= 0 (got " + std::to_string(v) + ")");
    }
  };
  non_negative(c.overlay_min_radius_m, "overlay_min_radius_m");
  non_negative(c.release_force_N, "release_force_N");
  non_negative(c.release_distance_m, "release_distance_m");
  if (!std::isfinite(c.steering_time_constant_s) || c.steering_time_constant_s <= 0.0) {
    throw Error("cobot wall: steering_time_constant_s must be > 0");
  }
  if (!std::isfinite(c.guard.margin) || c.guard.margin <= 0.0 || c.guard.margin > 1.0) {
    throw Error("cobot wall: stability margin must be in (0, 1] (got " + std::to_string(c.guard.margin) + ")");
  }
}

VirtualWallController::VirtualWallController(const VirtualWallConfig& config, const Constraint& wall)
    : config_(config), wall_(wall), overlay_(wall), tracker_(config.tracker) {
  Validate(config_);
}

void VirtualWallController::SetWall(const Constraint& wall, bool keep_mode) noexcept {
  wall_ = wall;
  if (!keep_mode) {
    mode_ = WallMode::kCaster;
    tracker_.Reset();
  }
}

void VirtualWallController::SetWallActive(bool active) noexcept {
  wall_active_ = active;
  if (!active) {
    mode_ = WallMode::kCaster;
  }
}

void VirtualWallController::UpdateMode(const WallControllerInput& in, const Vec2& force, double motion_heading,
                                       WallControllerOutput& out) noexcept {
  if (!wall_active_) {
    mode_ = WallMode::kCaster;
    return;
  }
  const ConstraintSample wall = wall_.Evaluate(in.position_m);
  const TrackingErrors wall_errors = ComputeTrackingErrors(wall, motion_heading);
  out.penetration_m = wall.penetration_m;
  const bool pulled_off_wall = force.dot(wall.normal_in) < -config_.release_force_N;
  switch (mode_) {
    case WallMode::kCaster: {
      if (wall.penetration_m > 0.0) {
        mode_ = WallMode::kTracking;
        tracker_.Reset();
        ++engage_count_;
      } else if (config_.overlay_enabled) {
        const OverlayArc arc = ComputeOverlay(wall, in.position_m, motion_heading);
        out.overlay_radius_m = arc.valid ? arc.radius_m : 0.0;
        if (arc.valid && arc.radius_m < config_.overlay_min_radius_m && !pulled_off_wall) {
          if (Constraint::TryCircle(arc.center_m, arc.radius_m, /*forbidden_outside=*/true, overlay_)) {
            mode_ = WallMode::kOverlay;
          } else {
            mode_ = WallMode::kTracking;  // degenerate arc: the wheel is at the wall already
          }
          tracker_.Reset();
          ++engage_count_;
        }
      }
      break;
    }
    case WallMode::kOverlay: {
      const ConstraintSample arc = overlay_.Evaluate(in.position_m);
      out.overlay_radius_m = overlay_.radius_m();
      if (force.dot(arc.normal_in) < -config_.release_force_N) {
        mode_ = WallMode::kCaster;
        ++release_count_;
      } else if (wall.penetration_m > 0.0 || wall_errors.theta_rad <= 0.0) {
        mode_ = WallMode::kTracking;  // keep the integral: the same turn continues
      }
      break;
    }
    case WallMode::kTracking: {
      if (pulled_off_wall || wall.penetration_m < -config_.release_distance_m) {
        mode_ = WallMode::kCaster;
        ++release_count_;
      }
      break;
    }
  }
}

WallControllerOutput VirtualWallController::Step(const WallControllerInput& in, double period_s) noexcept {
  WallControllerOutput out;
  const double u = std::isfinite(in.speed_m_per_s) ? in.speed_m_per_s : 0.0;
  const Vec2 force = in.handle_force_N.allFinite() ? in.handle_force_N : Vec2::Zero();
  const double motion_heading = u >= 0.0 ? in.steering_angle_rad : in.steering_angle_rad + std::numbers::pi;
  UpdateMode(in, force, motion_heading, out);

  if (mode_ == WallMode::kCaster) {
    const CasterOutput caster =
        VirtualCasterStep(config_.caster, force.x(), force.y(), in.steering_angle_rad, u, in.steering_rate_rad_per_s);
    out.steering_torque_Nm = caster.steering_torque_Nm;
    out.commanded_rate_rad_per_s = caster.commanded_rate_rad_per_s;
  } else {
    const ConstraintSample tracked =
        mode_ == WallMode::kOverlay ? overlay_.Evaluate(in.position_m) : wall_.Evaluate(in.position_m);
    out.stability = EvaluateStability(config_.guard, config_.tracker, config_.steering_time_constant_s,
                                      tracked.curvature_away_per_m, u);
    const TrackerOutput track = tracker_.Step(tracked, in.steering_angle_rad, u, in.steering_rate_rad_per_s, period_s,
                                              out.stability.lookahead_m);
    out.steering_torque_Nm = track.steering_torque_Nm;
    out.commanded_rate_rad_per_s = track.commanded_rate_rad_per_s;
    out.theta_rad = track.errors.theta_rad;
    out.brake_command = out.stability.brake_command;
  }
  out.mode = mode_;
  return out;
}

}  // namespace teleop::device::cobot
