#include "coupling.hpp"

#include "teleop/device/law_command.hpp"

namespace teleop::node {

namespace {

/// A config built in code may leave the controller's config unsized.
control::PassivityController::Config PassivityConfigOf(const Coupling::Config& cfg) {
  control::PassivityController::Config pc = cfg.passivity;
  pc.dof = cfg.dof;
  if (pc.max_damping_Ns_per_m.size() != cfg.dof) pc.max_damping_Ns_per_m = ZeroDof(cfg.dof);
  pc.max_force_N = cfg.law.max_force_N;
  return pc;
}

/// The clutch's hold: the configured safety section with reaction hold.
SafetyConfig HoldSafety(const SafetyConfig& safety) {
  SafetyConfig s = safety;
  s.reaction = Reaction::kHold;
  return s;
}

}  // namespace

Coupling::Coupling(const Config& config, EventLog& events)
    : config_(config),
      events_(events),
      clutch_({config.role == Role::kMaster, config.can_push}),
      setpoints_({config.dof}),
      law_input_({config.dof, config.role == Role::kMaster, config.measures_velocity, config.law.peer_position_scale,
                  config.engagement}),
      law_(config.law),
      reactions_{SafeReaction(config.safety, config.law), SafeReaction(HoldSafety(config.safety), config.law)},
      shaper_(
          {config.dof, config.role == Role::kMaster, config.law.max_force_N, config.engagement.max_force_rate_N_per_s}),
      passivity_(PassivityConfigOf(config)) {
  state_.last_velocity = ZeroDof(config.dof);
}

// The stages in order; each takes values and returns its own.
Applied Coupling::Step(const Sensed& sensed, const PeerView& peer, const Changes& changes, std::uint64_t cycle,
                       double t_s, double period_s) noexcept {
  Applied a;
  const proto::SampleMessage* sample = peer.have_peer ? peer.sample : nullptr;
  const Clutch::Output clutch = StepClutch(sensed, peer, changes, cycle);
  a.transition = engagement_.Update(clutch.blocker, shaper_.state().aligned_verdict, t_s);
  StepSetpoints(changes, period_s);
  const LawInputStage::Output in = law_input_.Step(
      {sensed.reading, sample, engagement_.coupling(), engagement_.state() == EngagementState::kAligning, a.transition,
       clutch.sources != 0, clutch.clutch_path, &state_.last_velocity, &shaper_.last_coupling_N(), t_s, period_s},
      reactions_);
  if (in.reindexed) {
    law_.ShiftPosition(in.shift_m);
    events_.Push({Event::Kind::kReindexed, cycle, in.largest_offset_m});
  }
  a.law = law_.Step(in.input, period_s);
  a.fixture_stiffness_N_per_m = law_.fixture().config().stiffness_N_per_m;
  a.nonfinite = a.law.status == control::ThreeChannelLaw::StepStatus::kNonFiniteInput;
  if (a.nonfinite) {
    a.transition.coupling_lost =
        engagement_.Update(Outage::kNonFiniteInput, false, t_s).coupling_lost || a.transition.coupling_lost;
  }
  PushEngagementEvents(a.transition, cycle);
  const CouplingPath path = PathOf(sensed.local_faults, a.nonfinite, clutch.clutch_path);
  Shaper::Output shaped =
      shaper_.Step({path, &a.law, in.aligned, a.transition.aligning_started, t_s, period_s}, reactions_);
  const bool may_act =
      !shaped.safe && !(path == CouplingPath::kReaction && reactions_.reaction.reaction() == Reaction::kZeroForce);
  if (changes.has_passivity) passivity_.SwitchMode(changes.passivity_mode);
  PassivityPort::Output port =
      passivity_.Step({&shaped.command.command_N, &a.law.velocity_m_per_s, may_act, sample}, period_s);
  shaped.command.command_N = port.force_N;
  shaper_.Track(path, a.law, shaped, a.transition.engaged, period_s);
  state_.last_velocity = a.law.velocity_m_per_s;
  a.command = shaped.command;
  a.safe = shaped.safe;
  a.damping_Ns_per_m = port.damping_Ns_per_m;
  a.passivity = port.energies;
  a.passivity_mode = passivity_.controller().config().mode;
  a.law_input = in.input;
  a.peer_local_m = in.peer_local_m;
  a.engagement = engagement_.state();
  a.reaction = reactions_.reaction.reaction();
  a.clutch_sources = clutch.sources;
  a.clutch_flag = clutch.flag;
  if (!a.safe) device::FillCommand(a.command, law_.fixture(), a.law_input.position_m, a.device_command);
  return a;
}

Clutch::Output Coupling::StepClutch(const Sensed& sensed, const PeerView& peer, const Changes& changes,
                                    std::uint64_t cycle) noexcept {
  Clutch::Input in;
  in.device_pressed = sensed.reading->clutch_pressed;
  in.command_pressed = changes.command_clutch;
  in.peer_pressed = peer.have_peer && peer.fresh && (peer.sample->flags & proto::kFlagClutched) != 0;
  in.blocker = Blocker(sensed.local_faults, peer);
  in.index_pending = law_input_.state().index_pending;
  const Clutch::Output out = clutch_.Step(in);
  if (out.pressed) events_.Push({Event::Kind::kClutchPressed, cycle, static_cast<double>(out.sources)});
  if (out.released) events_.Push({Event::Kind::kClutchReleased, cycle, 0.0});
  return out;
}

void Coupling::StepSetpoints(const Changes& changes, double period_s) noexcept {
  const Setpoints::Output out = setpoints_.Step(changes, law_.config(), law_.fixture().config(), period_s);
  if (out.set_stiffness) law_.SetFixtureStiffness(out.stiffness_N_per_m);
  if (out.set_gains) law_.SetGains(out.gains[0], out.gains[1], out.gains[2], out.gains[3]);
  if (out.set_plane) law_.SetFixturePlane(out.plane, out.normal, out.offset_m);
}

void Coupling::PushEngagementEvents(const EngagementMachine::Transition& tr, std::uint64_t cycle) noexcept {
  if (tr.coupling_lost) {
    events_.Push({Event::Kind::kCouplingLost, cycle, static_cast<double>(engagement_.last_outage())});
  }
  if (tr.aligning_started) events_.Push({Event::Kind::kAligning, cycle, 0.0});
  if (tr.engaged) events_.Push({Event::Kind::kEngaged, cycle, engagement_.aligning_max_s()});
}

CouplingPath Coupling::PathOf(std::uint32_t local_faults, bool nonfinite, bool clutch_path) const noexcept {
  if (local_faults != device::kFaultNone) return CouplingPath::kDeviceFault;
  if (nonfinite) return CouplingPath::kNonFinite;
  if (!engagement_.coupling()) return clutch_path ? CouplingPath::kClutched : CouplingPath::kReaction;
  return engagement_.state() == EngagementState::kAligning ? CouplingPath::kAligning : CouplingPath::kEngaged;
}

}  // namespace teleop::node
