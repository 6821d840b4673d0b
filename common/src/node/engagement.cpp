#include "teleop/node/engagement.hpp"

#include <algorithm>
#include <cmath>

namespace teleop::node {

const char* ToString(EngagementState state) noexcept {
  switch (state) {
    case EngagementState::kDisengaged:
      return "disengaged";
    case EngagementState::kHandshaking:
      return "handshaking";
    case EngagementState::kAligning:
      return "aligning";
    case EngagementState::kEngaged:
      return "engaged";
  }
  return "?";
}

const char* ToString(Outage outage) noexcept {
  switch (outage) {
    case Outage::kNone:
      return "none";
    case Outage::kDeviceFault:
      return "device fault";
    case Outage::kNonFiniteInput:
      return "non-finite input";
    case Outage::kNoPeer:
      return "no peer yet";
    case Outage::kLinkFault:
      return "link fault";
    case Outage::kPeerLost:
      return "peer lost";
    case Outage::kPeerShutdown:
      return "peer shutdown";
    case Outage::kPeerFault:
      return "peer fault";
    case Outage::kNewSession:
      return "new session";
    case Outage::kLatency:
      return "latency gate";
    case Outage::kClutch:
      return "clutch";
    case Outage::kCount:
      break;
  }
  return "?";
}

EngagementMachine::Transition EngagementMachine::Update(Outage blocker, bool aligned, double t_s) noexcept {
  Transition tr;
  const EngagementState before = state_;
  if (blocker != Outage::kNone) {
    last_outage_ = blocker;
    state_ = IsLocal(blocker) ? EngagementState::kDisengaged : EngagementState::kHandshaking;
  } else if (state_ == EngagementState::kDisengaged || state_ == EngagementState::kHandshaking) {
    state_ = EngagementState::kAligning;
    aligning_since_s_ = t_s;
    tr.aligning_started = true;
  } else if (state_ == EngagementState::kAligning && aligned) {
    state_ = EngagementState::kEngaged;
    const double d = t_s - aligning_since_s_;
    ++alignings_completed_;
    aligning_sum_s_ += d;
    aligning_max_s_ = std::max(aligning_max_s_, d);
    ++engagements_;
    tr.engaged = true;
  }
  const bool was_coupling = before == EngagementState::kAligning || before == EngagementState::kEngaged;
  if (was_coupling && !coupling()) {
    tr.coupling_lost = true;
    ++couplings_lost_;
  }
  return tr;
}

Aligner::Aligner(const EngagementConfig& config, int dof)
    : config_(config), reference_m_(DofVector::Zero(dof)), velocity_m_per_s_(DofVector::Zero(dof)) {}

void Aligner::Start(const DofVector& local_position_m, double t_s) noexcept {
  reference_m_ = local_position_m;
  velocity_m_per_s_.setZero();
  start_s_ = t_s;
  last_step_m_ = 0.0;
  ramp_ = 0.0;
  aligned_ = false;
  caught_up_ = false;
}

const DofVector& Aligner::Step(const DofVector& peer_position_m, double t_s, double period_s) noexcept {
  const double max_step = config_.align_speed_m_per_s * period_s;
  bool reached = true;
  last_step_m_ = 0.0;
  for (int i = 0; i < reference_m_.size(); ++i) {
    const double gap = peer_position_m[i] - reference_m_[i];
    const double step = std::clamp(gap, -max_step, max_step);
    reference_m_[i] += step;
    velocity_m_per_s_[i] = period_s > 0.0 ? step / period_s : 0.0;
    last_step_m_ = std::max(last_step_m_, std::abs(step));
    if (std::abs(peer_position_m[i] - reference_m_[i]) > config_.align_tolerance_m) reached = false;
  }
  const double min_s = config_.align_min_time_ms * 1e-3;
  const double elapsed = t_s - start_s_;
  ramp_ = min_s > 0.0 ? std::clamp(elapsed / min_s, 0.0, 1.0) : 1.0;
  caught_up_ = reached;
  aligned_ = reached && ramp_ >= 1.0;
  return reference_m_;
}

const DofVector& ForceRateLimiter::Limit(const DofVector& desired_N, double max_rate_N_per_s,
                                         double period_s) noexcept {
  const double max_step = max_rate_N_per_s * period_s;
  clipped_ = false;
  if (last_N_.size() != desired_N.size()) last_N_ = DofVector::Zero(desired_N.size());
  for (int i = 0; i < desired_N.size(); ++i) {
    const double step = desired_N[i] - last_N_[i];
    const double limited = std::clamp(step, -max_step, max_step);
    if (limited != step) clipped_ = true;
    last_N_[i] += limited;
  }
  return last_N_;
}

}  // namespace teleop::node
