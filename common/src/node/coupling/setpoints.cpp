#include "setpoints.hpp"

#include <algorithm>
#include <cmath>

namespace teleop::node {

namespace {

/// The unit vector from `now` toward `target` turned by at most `max_angle` rad along the great circle.
DofVector TurnToward(const DofVector& now, const DofVector& target, double cosine, double max_angle) noexcept {
  // The unit direction in the plane of the two normals, orthogonal to the current one; for an opposite target
  // (no such plane) the axis along which the current normal is smallest, made orthogonal.
  DofVector dir = target - cosine * now;
  if (dir.norm() < 1e-9) {
    int axis = 0;
    now.cwiseAbs().minCoeff(&axis);
    dir.setZero();
    dir[axis] = 1.0;
    dir -= now.dot(dir) * now;
  }
  if (dir.norm() < 1e-9) dir = target;  // 1 DOF (refused by the node before)
  dir /= dir.norm();
  DofVector turned = std::cos(max_angle) * now + std::sin(max_angle) * dir;
  turned /= turned.norm();
  return turned;
}

}  // namespace

Setpoints::Setpoints(const Config& config) : config_(config) {
  const DofVector zero = ZeroDof(config.dof);
  for (int g = 0; g < 4; ++g) {
    state_.gains.from[static_cast<std::size_t>(g)] = zero;
    state_.gains.to[static_cast<std::size_t>(g)] = zero;
  }
  state_.slew.normal = zero;
}

Setpoints::Output Setpoints::Step(const Changes& changes, const control::ThreeChannelLaw::Config& law,
                                  const control::ForbiddenRegionFixture::Config& fixture, double period_s) noexcept {
  Start(changes, law, fixture);
  Output out;
  if (state_.stiffness.active) StepStiffness(period_s, out);
  if (state_.gains.active) StepGains(period_s, out);
  if (state_.slew.active) StepPlane(fixture.planes[static_cast<std::size_t>(state_.slew.plane)], period_s, out);
  return out;
}

void Setpoints::Start(const Changes& changes, const control::ThreeChannelLaw::Config& law,
                      const control::ForbiddenRegionFixture::Config& fixture) noexcept {
  if (changes.has_stiffness) {
    state_.stiffness = {true, fixture.stiffness_N_per_m, changes.stiffness.target_N_per_m,
                        changes.stiffness.ramp_s > 0.0 ? changes.stiffness.ramp_s : 0.0, 0.0};
  }
  if (changes.has_gains) {
    State::GainRamp& g = state_.gains;
    g.from = {law.kp_N_per_m, law.kd_Ns_per_m, law.kv_Ns_per_m, law.kf};
    g.to = {changes.gains.kp_N_per_m, changes.gains.kd_Ns_per_m, changes.gains.kv_Ns_per_m, changes.gains.kf};
    g.ramp_s = changes.gains.ramp_s > 0.0 ? changes.gains.ramp_s : 0.0;
    g.elapsed_s = 0.0;
    g.active = true;
  }
  const Changes::PlaneMove& move = changes.plane;
  if (changes.has_plane && move.index >= 0 && move.index < fixture.plane_count && move.normal.size() == config_.dof) {
    state_.slew = {true, move.index, move.normal, move.offset_m, move.offset_rate_m_per_s, move.normal_rate_rad_per_s};
  }
}

void Setpoints::StepStiffness(double period_s, Output& out) noexcept {
  State::StiffnessRamp& r = state_.stiffness;
  r.elapsed_s += period_s;
  const double u = r.ramp_s > 0.0 ? std::min(r.elapsed_s / r.ramp_s, 1.0) : 1.0;
  out.set_stiffness = true;
  out.stiffness_N_per_m = r.from_N_per_m + u * (r.to_N_per_m - r.from_N_per_m);
  r.active = u < 1.0;
}

void Setpoints::StepGains(double period_s, Output& out) noexcept {
  State::GainRamp& r = state_.gains;
  r.elapsed_s += period_s;
  const double u = r.ramp_s > 0.0 ? std::min(r.elapsed_s / r.ramp_s, 1.0) : 1.0;
  for (std::size_t g = 0; g < 4; ++g) {
    out.gains[g] =
        u >= 1.0 ? r.to[g] : DofVector(r.from[g] + u * (r.to[g] - r.from[g]));  // exactly the target at the end
  }
  out.set_gains = true;
  r.active = u < 1.0;
}

void Setpoints::StepPlane(const control::FixturePlane& now, double period_s, Output& out) noexcept {
  // Offset: toward the target by at most rate · period. Normal: along the great circle from the current normal to
  // the target by at most rate · period (rad). With a still device the fixture force K·d·n then changes per cycle by
  // at most K·period·(offset rate + normal rate·(|x| + d)) (eq. 7: F = K·d, d = n·x - offset).
  State::PlaneSlew& s = state_.slew;
  const double max_offset_step = s.offset_rate_m_per_s * period_s;
  const double offset_step = std::clamp(s.offset_m - now.offset_m, -max_offset_step, max_offset_step);
  const double offset =
      std::abs(s.offset_m - now.offset_m) <= max_offset_step ? s.offset_m : now.offset_m + offset_step;
  const double max_angle = s.normal_rate_rad_per_s * period_s;
  const double cosine = std::clamp(now.normal.dot(s.normal), -1.0, 1.0);
  const bool normal_done = std::acos(cosine) <= max_angle;
  out.normal = normal_done ? s.normal : TurnToward(now.normal, s.normal, cosine, max_angle);
  state_.max_plane_offset_step_m = std::max(state_.max_plane_offset_step_m, std::abs(offset - now.offset_m));
  state_.max_plane_normal_step_rad =
      std::max(state_.max_plane_normal_step_rad, std::acos(std::clamp(out.normal.dot(now.normal), -1.0, 1.0)));
  out.set_plane = true;
  out.plane = s.plane;
  out.offset_m = offset;
  s.active = !(normal_done && offset == s.offset_m);
}

}  // namespace teleop::node
