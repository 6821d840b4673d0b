#include "device/cobot/master_walls.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace teleop::device::cobot {

namespace {
/// Per-cycle weight of the free-motion fit (about 0.5 s at 1 kHz).
constexpr double kFreeAlpha = 0.002;
/// Velocity variance (m²/s²) below which the slope B is not trusted (the model then is the mean).
constexpr double kMinVelocityVariance = 1e-6;

/// A plane's offset in (x, y) at the plate's angle: the θ component moves the line.
double PlanarOffset(const device::Constraint& c, double angle_rad) noexcept {
  return c.normal.size() >= 3 ? c.offset_m - c.normal[2] * angle_rad : c.offset_m;
}

/// The most penetrated fixture plane of `command` at `position` (-1: none), its penetration in `penetration_m`.
int MostPenetrated(const Command& command, const Vec2& position, double angle_rad, double& penetration_m) noexcept {
  int best = -1;
  for (int i = 0; i < command.constraint_count; ++i) {
    const device::Constraint& c = command.constraints[static_cast<std::size_t>(i)];
    const double penetration = Vec2(c.normal[0], c.normal[1]).dot(position) - PlanarOffset(c, angle_rad);
    if (penetration > penetration_m) {
      penetration_m = penetration;
      best = i;
    }
  }
  return best;
}
}  // namespace

MasterWalls::MasterWalls(double contact_force_threshold_N) noexcept
    : threshold_N_(contact_force_threshold_N), contact_wall_(Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true)) {}

Vec2 MasterWalls::FreeCoupling_N(const Vec2& v) const noexcept {
  if (s_vv_ < kMinVelocityVariance) return mean_coupling_N_;
  // c ≈ c̄ + k·(v − v̄), k = s_cv/s_vv (k = −B, the lag's slope; not signed on purpose: whatever the law does).
  return mean_coupling_N_ + (s_cv_ / s_vv_) * (v - mean_velocity_);
}

void MasterWalls::LearnFreeMotion(const Vec2& c, const Vec2& v) noexcept {
  if (!primed_) {
    mean_coupling_N_ = c;
    mean_velocity_ = v;
    primed_ = true;
    return;
  }
  const Vec2 dc = c - mean_coupling_N_;
  const Vec2 dv = v - mean_velocity_;
  mean_coupling_N_ += kFreeAlpha * dc;
  mean_velocity_ += kFreeAlpha * dv;
  // West's exponentially weighted co-moment update.
  s_cv_ = (1.0 - kFreeAlpha) * (s_cv_ + kFreeAlpha * dc.dot(dv));
  s_vv_ = (1.0 - kFreeAlpha) * (s_vv_ + kFreeAlpha * dv.squaredNorm());
}

void MasterWalls::TrackContact(const Command& command, const Vec2& position, const Vec2& velocity,
                               const VirtualWallController& controller) noexcept {
  // A blocked slave: the coupling force (the law's force without the fixture's share) over what free motion at
  // this velocity explains.
  Vec2 coupling(command.force_N[0], command.force_N[1]);
  if (command.fixture_force_N.size() >= 2) coupling -= Vec2(command.fixture_force_N[0], command.fixture_force_N[1]);
  const Vec2 contact_force = coupling - FreeCoupling_N(velocity);
  const double contact_N = contact_force.norm();
  if (!contact_latched_ && contact_N > threshold_N_) {
    const Vec2 normal = -contact_force / contact_N;
    if (Constraint::TryHalfPlane(normal, normal.dot(position), contact_wall_)) {
      contact_latched_ = true;
      contact_point_m_ = position;
      contact_normal_ = normal;
      first_normal_ = normal;
      excess_sum_N_ = contact_force;
    }
  } else if (!contact_latched_) {
    LearnFreeMotion(coupling, velocity);
  } else if (contact_N > threshold_N_) {
    // Still pressed: refine the normal from every excess above the threshold, about the contact point.
    excess_sum_N_ += contact_force;
    const double n = excess_sum_N_.norm();
    Constraint refined = contact_wall_;
    if (n > 0.0 && Constraint::TryHalfPlane(-excess_sum_N_ / n, (-excess_sum_N_ / n).dot(contact_point_m_), refined)) {
      contact_normal_ = -excess_sum_N_ / n;
      contact_wall_ = refined;
    }
  } else if (contact_N < 0.5 * threshold_N_ && !(source_ == kContactWall && controller.mode() != WallMode::kCaster)) {
    // Released only once the operator has left the contact wall (the controller is back in caster mode): the
    // coupling force dips while the wheel settles on the wall, and re-latching deeper each time would weave.
    contact_latched_ = false;
  }
}

void MasterWalls::Apply(const Command& command, const Vec2& position, const Vec2& velocity_in,
                        VirtualWallController& controller, double angle_rad) noexcept {
  const Vec2 velocity = velocity_in.allFinite() ? velocity_in : Vec2::Zero();
  const double angle = std::isfinite(angle_rad) ? angle_rad : 0.0;
  double best_penetration = -std::numeric_limits<double>::infinity();
  const int best = MostPenetrated(command, position, angle, best_penetration);
  TrackContact(command, position, velocity, controller);
  int source = -1;
  Constraint wall = contact_wall_;
  const double contact_penetration = contact_wall_.Evaluate(position).penetration_m;
  if (contact_latched_ && (best < 0 || contact_penetration >= best_penetration)) {
    source = kContactWall;
  } else if (best >= 0) {
    const device::Constraint& c = command.constraints[static_cast<std::size_t>(best)];
    if (Constraint::TryHalfPlane(Vec2(c.normal[0], c.normal[1]), PlanarOffset(c, angle), wall)) source = best;
  }
  if (source < 0) {
    controller.SetWallActive(false);
  } else {
    controller.SetWallActive(true);
    controller.SetWall(wall, /*keep_mode=*/source == source_);
  }
  source_ = source;
}

}  // namespace teleop::device::cobot
