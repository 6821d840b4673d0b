#include "shaper.hpp"

#include <algorithm>

namespace teleop::node {

namespace {

double MaxAbs(const DofVector& v) noexcept { return v.size() > 0 ? v.cwiseAbs().maxCoeff() : 0.0; }

bool WithFixture(Reaction r) noexcept {
  return r == Reaction::kHold || r == Reaction::kDecelerate || r == Reaction::kFade;
}

}  // namespace

Shaper::Shaper(const Config& config) : config_(config), limiter_(config.dof) {}

Shaper::Output Shaper::Step(const Input& in, Reactions& reactions) noexcept {
  const control::ThreeChannelLaw::Output& law = *in.law;
  Output out;
  control::ThreeChannelLaw::Output& cmd = out.command;
  cmd = law;
  if (in.aligning_started) state_.aligned_verdict = false;
  switch (in.path) {
    case CouplingPath::kDeviceFault:
      out.safe = true;
      break;
    case CouplingPath::kNonFinite:  // the law's zero command
      cmd.fixture_force_N.setZero();
      break;
    case CouplingPath::kAligning:
      // The coupling part ramps in at a bounded rate; the fixture's share is never limited.
      Limit(law.command_N - law.fixture_force_N, law, in.period_s, state_.max_aligning_force_rate, out);
      state_.aligned_verdict = in.aligned && !limiter_.clipped();
      break;
    case CouplingPath::kEngaged:
      break;
    case CouplingPath::kClutched:
      Clutched(in, reactions, out);
      break;
    case CouplingPath::kReaction:
      out.safe = !reactions.reaction.Command(law, in.t_s, cmd.command_N);
      if (!WithFixture(reactions.reaction.reaction())) cmd.fixture_force_N.setZero();
      break;
  }
  if (out.safe) {
    cmd.command_N = ZeroDof(config_.dof);
    cmd.fixture_force_N.setZero();
  }
  return out;
}

void Shaper::Limit(const DofVector& coupling_N, const control::ThreeChannelLaw::Output& law, double period_s,
                   double& max_rate, Output& out) noexcept {
  const DofVector before = limiter_.last_N();
  out.command.command_N = limiter_.Limit(coupling_N, config_.max_force_rate_N_per_s, period_s) + law.fixture_force_N;
  const double max_force_N = config_.max_force_N;
  if (max_force_N > 0.0) out.command.command_N = out.command.command_N.cwiseMax(-max_force_N).cwiseMin(max_force_N);
  max_rate = std::max(max_rate, MaxAbs(limiter_.last_N() - before) / period_s);
}

void Shaper::Clutched(const Input& in, Reactions& reactions, Output& out) noexcept {
  // The coupling part moves to the clutch's target (slave: the hold's force; master: none) at the bounded force
  // rate, so neither the press nor a release mid-fade steps the force; the fixture's share is never limited.
  const control::ThreeChannelLaw::Output& law = *in.law;
  DofVector target_N = ZeroDof(config_.dof);
  if (!config_.master) {
    (void)reactions.clutch_hold.Command(law, in.t_s, target_N);  // hold never asks for the safe state
    target_N -= law.fixture_force_N;
  }
  Limit(target_N, law, in.period_s, state_.max_clutch_force_rate, out);
}

void Shaper::Track(CouplingPath path, const control::ThreeChannelLaw::Output& law, const Output& applied,
                   bool engaged_now, double period_s) noexcept {
  const DofVector& applied_N = applied.command.command_N;
  switch (path) {
    case CouplingPath::kEngaged: {
      const DofVector coupling = applied_N - law.fixture_force_N;
      if (engaged_now) {
        state_.max_aligning_force_rate =
            std::max(state_.max_aligning_force_rate, MaxAbs(coupling - limiter_.last_N()) / period_s);
      }
      limiter_.Track(coupling);
      break;
    }
    case CouplingPath::kReaction:
      limiter_.Track(applied_N - applied.command.fixture_force_N);
      break;
    case CouplingPath::kDeviceFault:
      limiter_.Track(applied_N);
      break;
    case CouplingPath::kAligning:  // the limiter holds what it let through
    case CouplingPath::kClutched:
    case CouplingPath::kNonFinite:
      break;
  }
}

}  // namespace teleop::node
