#pragma once

#include <cstdint>

#include "device/cobot/constraint.hpp"
#include "device/cobot/constraint_overlay.hpp"
#include "device/cobot/constraint_tracker.hpp"
#include "device/cobot/tracking_stability.hpp"
#include "device/cobot/virtual_caster.hpp"

namespace teleop::device::cobot {

/// The virtual wall of Colgate et al. §5: the virtual caster in free space, constraint tracking on the wall.
///  - caster → tracking when the wheel crosses the wall (p > 0), or, with the overlay on, tracking of the overlay arc
///    when its radius falls below overlay_min_radius_m (the turn starts before contact);
///  - overlay → tracking of the wall when the wheel's motion is tangent to the wall (θ ≤ 0) or it touches it;
///  - tracking (wall or overlay) → caster when the operator's force points away from the wall by more than
///    release_force_N (a pull off the wall), or the wheel has left the wall by more than release_distance_m.
/// The wall is unilateral: pushing into it is ignored, pulling away is free.
struct VirtualWallConfig {
  VirtualCasterConfig caster{};
  ConstraintTrackerConfig tracker{};
  StabilityGuardConfig guard{};
  bool overlay_enabled = true;
  double overlay_min_radius_m = 0.1;
  double release_force_N = 1.0;
  double release_distance_m = 0.01;
  double steering_time_constant_s = 0.02;  ///< τ of the steering loop (J/(K₂ + b)), for the eq 10 guard.
};

enum class WallMode : std::uint8_t { kCaster, kOverlay, kTracking };
const char* ToString(WallMode mode) noexcept;

/// What the controller sees in one cycle.
struct WallControllerInput {
  Vec2 position_m = Vec2::Zero();        ///< Measured wheel position (m, world).
  double steering_angle_rad = 0.0;       ///< Measured heading.
  double speed_m_per_s = 0.0;            ///< Estimated u.
  double steering_rate_rad_per_s = 0.0;  ///< Estimated ω.
  Vec2 handle_force_N = Vec2::Zero();    ///< Measured operator force (N, world).
};

struct WallControllerOutput {
  double steering_torque_Nm = 0.0;
  double commanded_rate_rad_per_s = 0.0;  ///< ω_c of the caster or the tracker (world heading rate).
  double brake_command = 0.0;
  WallMode mode = WallMode::kCaster;
  double penetration_m = 0.0;     ///< p against the wall (not the overlay).
  double theta_rad = 0.0;         ///< θ against the constraint being tracked.
  double overlay_radius_m = 0.0;  ///< Current overlay radius (0 when none).
  StabilityStatus stability{};
};

/// Throws teleop::Error naming the first bad field.
void Validate(const VirtualWallConfig& config);

class VirtualWallController {
 public:
  VirtualWallController(const VirtualWallConfig& config, const Constraint& wall);
  /// Replaces the wall (set-up or between cycles); keeps the mode when `keep_mode`, else back to caster.
  void SetWall(const Constraint& wall, bool keep_mode = false) noexcept;
  /// No wall at all: pure caster (the wall is remembered but ignored).
  void SetWallActive(bool active) noexcept;
  [[nodiscard]] WallControllerOutput Step(const WallControllerInput& in, double period_s) noexcept;
  WallMode mode() const noexcept { return mode_; }
  const Constraint& wall() const noexcept { return wall_; }
  const VirtualWallConfig& config() const noexcept { return config_; }
  /// Count of caster → tracking/overlay and back transitions.
  int engage_count() const noexcept { return engage_count_; }
  int release_count() const noexcept { return release_count_; }

 private:
  /// Step's first part: the mode after this cycle's wall sample (engage, overlay, release), with the penetration
  /// and the overlay's radius in `out`.
  void UpdateMode(const WallControllerInput& in, const Vec2& force, double motion_heading,
                  WallControllerOutput& out) noexcept;
  VirtualWallConfig config_;
  Constraint wall_;
  Constraint overlay_;
  ConstraintTracker tracker_;
  WallMode mode_ = WallMode::kCaster;
  bool wall_active_ = true;
  int engage_count_ = 0;
  int release_count_ = 0;
};

}  // namespace teleop::device::cobot
