#pragma once

#include "device/cobot/constraint.hpp"
#include "device/cobot/planar.hpp"
#include "device/cobot/virtual_wall.hpp"
#include "teleop/device/device.hpp"

namespace teleop::device::cobot {

/// What a unicycle cobot master renders from the law's Command (docs/cobot.md, "As a master"), shared by the
/// simulated and the fieldbus rig:
///  - each fixture plane as a steered virtual wall (the most penetrated one at a time);
///  - a blocked slave as a wall through the master's position when the contact began, normal to the contact force.
///
/// The contact force is the coupling force (the law's force without the fixture's share) minus what free motion
/// explains. In free motion the coupling force is the slave's lag, which grows with the master's velocity (the
/// loop's round-trip delay times the coupling stiffness, plus the slave's dynamics): the free-motion model is
/// c ≈ c̄ − B·(v − v̄), an exponentially weighted least-squares fit (about 0.5 s) of the coupling force against the
/// master velocity v while there is no contact. The excess over the model is the contact force. Its direction at
/// the threshold crossing is still mostly noise (2 N against a few tenths of a newton of lag jitter), so the normal
/// is re-estimated while the contact lasts: the direction of the sum of the excess vectors above the threshold
/// (larger excesses weigh more), the wall pivoting about the point where the contact began.
class MasterWalls {
 public:
  static constexpr int kContactWall = 100;
  explicit MasterWalls(double contact_force_threshold_N) noexcept;

  /// One cycle: picks the wall for `command` (which must be usable: sizes and finiteness checked by the caller)
  /// and sets it on `controller`. Real-time safe. A plane with a θ component (a bicycle's n·(x, y, θ) ≥ offset) is
  /// rendered as its slice at the plate's angle `angle_rad`: n_xy·(x, y) ≥ offset − n_θ·θ, a line that moves as the
  /// plate turns (the wheels constrain the reference point, not θ; a plane with no x, y part cannot be a wall).
  void Apply(const Command& command, const Vec2& position_m, const Vec2& velocity_m_per_s,
             VirtualWallController& controller, double angle_rad = 0.0) noexcept;

  /// -1 none, 0..kMaxConstraints-1 a fixture plane, kContactWall the contact wall.
  int source() const noexcept { return source_; }
  bool contact_latched() const noexcept { return contact_latched_; }
  /// The contact wall's normal (unit, pointing out of the forbidden side, i.e. against the contact force).
  const Vec2& contact_normal() const noexcept { return contact_normal_; }
  /// The normal estimated at the threshold crossing, before the re-estimation (for tests and telemetry).
  const Vec2& first_contact_normal() const noexcept { return first_normal_; }
  /// The coupling force free motion would give at velocity `v` (the model above).
  Vec2 FreeCoupling_N(const Vec2& v) const noexcept;

 private:
  void LearnFreeMotion(const Vec2& coupling, const Vec2& velocity) noexcept;
  /// Apply's contact wall: latches it when the coupling force exceeds what free motion explains, refines its
  /// normal while pressed, releases it once the operator has left it.
  void TrackContact(const Command& command, const Vec2& position, const Vec2& velocity,
                    const VirtualWallController& controller) noexcept;

  double threshold_N_;
  int source_ = -1;
  bool contact_latched_ = false;
  Vec2 contact_point_m_ = Vec2::Zero();
  Vec2 contact_normal_ = Vec2(-1.0, 0.0);
  Vec2 first_normal_ = Vec2(-1.0, 0.0);
  Vec2 excess_sum_N_ = Vec2::Zero();
  Constraint contact_wall_;
  // Free-motion model: exponentially weighted means and co-moments.
  Vec2 mean_coupling_N_ = Vec2::Zero();
  Vec2 mean_velocity_ = Vec2::Zero();
  double s_cv_ = 0.0;  ///< E[(c − c̄)·(v − v̄)]
  double s_vv_ = 0.0;  ///< E[|v − v̄|²]
  bool primed_ = false;
};

}  // namespace teleop::device::cobot
