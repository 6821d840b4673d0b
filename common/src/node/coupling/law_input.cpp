#include "law_input.hpp"

#include <algorithm>
#include <cmath>

namespace teleop::node {

namespace {

void CopyFromWire(const std::array<double, proto::kMaxWireDof>& in, int dof, DofVector& out) noexcept {
  out.resize(dof);
  for (int i = 0; i < dof; ++i) out[i] = in[static_cast<std::size_t>(i)];
}

double MaxAbs(const DofVector& v) noexcept { return v.size() > 0 ? v.cwiseAbs().maxCoeff() : 0.0; }

}  // namespace

LawInputStage::LawInputStage(const Config& config) : config_(config), aligner_(config.engagement, config.dof) {
  const int dof = config.dof;
  control::ThreeChannelLaw::Input& input = state_.input;
  for (DofVector* v : {&input.position_m, &input.velocity_m_per_s, &input.peer_position_m, &input.peer_velocity_m_per_s,
                       &input.peer_force_N, &state_.index_offset_m, &state_.last_reference_m}) {
    *v = ZeroDof(dof);
  }
}

LawInputStage::Output LawInputStage::Step(const Input& in, Reactions& reactions) noexcept {
  if (in.clutched && config_.master) state_.index_pending = true;
  const device::Reading& reading = *in.reading;
  control::ThreeChannelLaw::Input& input = state_.input;
  input.position_m = reading.position_m + state_.index_offset_m;  // the offset is zero but on a re-indexed master
  input.has_velocity = config_.measures_velocity;
  input.velocity_m_per_s = reading.velocity_m_per_s;
  if (in.peer != nullptr) {
    CopyFromWire(in.peer->position_m, config_.dof, input.peer_position_m);
    CopyFromWire(in.peer->velocity_m_per_s, config_.dof, input.peer_velocity_m_per_s);
    CopyFromWire(in.peer->force_N, config_.dof, input.peer_force_N);
  }
  Output out;
  out.peer_local_m = config_.peer_position_scale * input.peer_position_m;
  if (in.coupling) {
    Coupled(in, out);
  } else {
    NotCoupled(in, reactions);
  }
  out.input = input;
  out.aligned = aligner_.aligned();
  return out;
}

void LawInputStage::NotCoupled(const Input& in, Reactions& reactions) noexcept {
  control::ThreeChannelLaw::Input& input = state_.input;
  if (in.clutch_path) {
    // Clutched: a slave holds where it is (the hold reaction); the master runs the law without a peer (its
    // fixture stays), the coupling force fades at the bounded rate (Shaper).
    state_.reaction_latched = false;
    if (config_.master) {
      input.peer_valid = false;
      return;
    }
    if (!state_.clutch_latched) {
      reactions.clutch_hold.Latch(input.position_m, *in.last_velocity, *in.last_coupling_N, in.t_s);
      state_.clutch_latched = true;
    }
    reactions.clutch_hold.PrepareInput(input, in.period_s);
    return;
  }
  state_.clutch_latched = false;
  if (!state_.reaction_latched) {
    reactions.reaction.Latch(input.position_m, *in.last_velocity, *in.last_coupling_N, in.t_s);
    state_.reaction_latched = true;
  }
  reactions.reaction.PrepareInput(input, in.period_s);
}

void LawInputStage::Coupled(const Input& in, Output& out) noexcept {
  control::ThreeChannelLaw::Input& input = state_.input;
  state_.reaction_latched = false;
  state_.clutch_latched = false;
  input.peer_valid = true;
  if (in.transition.aligning_started) {
    if (state_.index_pending) Reindex(*in.reading, out);
    aligner_.Start(input.position_m, in.t_s);
    state_.last_reference_m = input.position_m;
  }
  if (in.aligning) {
    Align(in, out.peer_local_m);
    return;
  }
  if (in.transition.engaged) {
    state_.max_reference_step_m =
        std::max(state_.max_reference_step_m, MaxAbs(out.peer_local_m - state_.last_reference_m));
  }
  state_.last_reference_m = out.peer_local_m;
}

void LawInputStage::Reindex(const device::Reading& reading, Output& out) noexcept {
  // Master, coupling resumes after a clutch: the offset that puts the (indexed) master where the slave is, in the
  // master's frame (the slave's position · peer_position_scale). The slave's reference is then its own position;
  // scaled axes stay scaled (the offset is added before the law and the wire, the motion keeps its scale).
  state_.index_pending = false;
  ++state_.reindexes;
  out.shift_m = ZeroDof(config_.dof);
  for (int i = 0; i < config_.dof; ++i) {
    const double offset = out.peer_local_m[i] - reading.position_m[i];
    out.shift_m[i] = offset - state_.index_offset_m[i];  // the shift of the law's frame
    state_.index_offset_m[i] = offset;
    out.largest_offset_m = std::max(out.largest_offset_m, std::abs(offset));
  }
  out.reindexed = true;
  state_.input.position_m = reading.position_m + state_.index_offset_m;
}

void LawInputStage::Align(const Input& in, const DofVector& peer_local_m) noexcept {
  // The law sees a peer that starts where this device is and moves to the real one at bounded speed.
  control::ThreeChannelLaw::Input& input = state_.input;
  const double scale = config_.peer_position_scale;
  const DofVector& ref = aligner_.Step(peer_local_m, in.t_s, in.period_s);
  state_.max_reference_step_m = std::max(state_.max_reference_step_m, aligner_.last_step_m());
  input.peer_position_m = ref / scale;
  // Once caught up the reference is the peer: its velocity is the peer's (no K_d step at the switch).
  if (!aligner_.caught_up()) input.peer_velocity_m_per_s = aligner_.reference_velocity_m_per_s() / scale;
  input.peer_force_N *= aligner_.ramp();
  state_.last_reference_m = ref;
}

}  // namespace teleop::node
