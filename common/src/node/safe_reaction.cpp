#include "teleop/node/safe_reaction.hpp"

#include <algorithm>
#include <cmath>

namespace teleop::node {

SafeReaction::SafeReaction(const SafetyConfig& safety, const control::ThreeChannelLaw::Config& law)
    : safety_(safety),
      position_scale_(law.peer_position_scale),
      max_force_N_(law.max_force_N),
      target_m_(DofVector::Zero(law.dof)),
      target_velocity_m_per_s_(DofVector::Zero(law.dof)),
      latched_coupling_N_(DofVector::Zero(law.dof)) {}

void SafeReaction::Latch(const DofVector& position_m, const DofVector& velocity_m_per_s,
                         const DofVector& coupling_force_N, double t_s) noexcept {
  const int dof = static_cast<int>(target_m_.size());
  for (int i = 0; i < dof; ++i) {
    const double x = i < position_m.size() ? position_m[i] : 0.0;
    const double v = i < velocity_m_per_s.size() ? velocity_m_per_s[i] : 0.0;
    const double f = i < coupling_force_N.size() ? coupling_force_N[i] : 0.0;
    // A non-finite latch (a bad reading at the loss) holds nothing rather than steering to NaN.
    target_m_[i] = std::isfinite(x) ? x : 0.0;
    target_velocity_m_per_s_[i] = safety_.reaction == Reaction::kDecelerate && std::isfinite(v) ? v : 0.0;
    latched_coupling_N_[i] = std::isfinite(f) ? f : 0.0;
  }
  latched_s_ = t_s;
}

void SafeReaction::PrepareInput(control::ThreeChannelLaw::Input& input, double period_s) noexcept {
  const int dof = static_cast<int>(target_m_.size());
  const bool virtual_peer = safety_.reaction == Reaction::kHold || safety_.reaction == Reaction::kDecelerate;
  input.peer_valid = virtual_peer;
  if (!virtual_peer) return;
  if (safety_.reaction == Reaction::kDecelerate && period_s > 0.0 && std::isfinite(period_s)) {
    const double dv = safety_.decelerate_m_per_s2 * period_s;
    for (int i = 0; i < dof; ++i) {
      double& v = target_velocity_m_per_s_[i];
      v = v > 0.0 ? std::max(0.0, v - dv) : std::min(0.0, v + dv);
      target_m_[i] += v * period_s;
    }
  }
  input.peer_position_m.resize(dof);
  input.peer_velocity_m_per_s.resize(dof);
  input.peer_force_N.resize(dof);
  for (int i = 0; i < dof; ++i) {
    input.peer_position_m[i] = target_m_[i] / position_scale_;
    input.peer_velocity_m_per_s[i] = target_velocity_m_per_s_[i] / position_scale_;
    input.peer_force_N[i] = 0.0;
  }
}

void SafeReaction::Clamp(DofVector& force_N, double limit_N) const noexcept {
  if (!(limit_N > 0.0)) return;
  for (int i = 0; i < force_N.size(); ++i) force_N[i] = std::clamp(force_N[i], -limit_N, limit_N);
}

bool SafeReaction::Command(const control::ThreeChannelLaw::Output& out, double t_s, DofVector& command_N) noexcept {
  const int dof = static_cast<int>(target_m_.size());
  command_N.resize(dof);
  switch (safety_.reaction) {
    case Reaction::kHold:
    case Reaction::kDecelerate:
      // The PD part bounded by hold_max_force_N, the fixture's share added back, then the actuator limit.
      command_N = out.command_N - out.fixture_force_N;
      for (int i = 0; i < dof; ++i) {
        command_N[i] = std::clamp(command_N[i], -safety_.hold_max_force_N, safety_.hold_max_force_N);
      }
      command_N += out.fixture_force_N;
      Clamp(command_N, max_force_N_);
      return true;
    case Reaction::kZeroForce:
      command_N.setZero();
      return true;
    case Reaction::kBrake:
      command_N.setZero();
      return false;
    case Reaction::kFade: {
      const double fade_s = safety_.fade_time_ms * 1e-3;
      const double left = fade_s > 0.0 ? std::clamp(1.0 - (t_s - latched_s_) / fade_s, 0.0, 1.0) : 0.0;
      command_N = out.command_N + left * latched_coupling_N_;
      Clamp(command_N, max_force_N_);
      return true;
    }
    case Reaction::kDamping:
      command_N = -safety_.damping_Ns_per_m * out.velocity_m_per_s;
      Clamp(command_N, max_force_N_);
      return true;
  }
  command_N.setZero();
  return true;
}

}  // namespace teleop::node
