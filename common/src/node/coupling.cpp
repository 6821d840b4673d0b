#include "coupling.hpp"

#include <algorithm>
#include <cmath>

namespace teleop::node {

namespace {

void CopyFromWire(const std::array<double, proto::kMaxWireDof>& in, int dof, DofVector& out) noexcept {
  out.resize(dof);
  for (int i = 0; i < dof; ++i) out[i] = in[static_cast<std::size_t>(i)];
}

double MaxAbs(const DofVector& v) noexcept { return v.size() > 0 ? v.cwiseAbs().maxCoeff() : 0.0; }

/// A config built in code may leave the controller's config unsized.
control::PassivityController::Config PassivityConfigOf(const config::ProcessConfig& cfg) {
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
      law_(config.process.law),
      passivity_(PassivityConfigOf(config.process)),
      aligner_(config.process.engagement, config.process.dof),
      limiter_(config.process.dof),
      reaction_(config.process.safety, config.process.law),
      clutch_hold_(HoldSafety(config.process.safety), config.process.law) {
  const int dof = config.process.dof;
  state_.last_velocity = ZeroDof(dof);
  state_.last_reference_m = ZeroDof(dof);
  state_.index_offset_m = ZeroDof(dof);
  hold_N_ = ZeroDof(dof);
  for (DofVector* v : {&input_.position_m, &input_.velocity_m_per_s, &input_.peer_position_m,
                       &input_.peer_velocity_m_per_s, &input_.peer_force_N, &passivity_input_.peer_input_energy_J,
                       &zero_, &applied_.damping_Ns_per_m, &applied_.peer_local_m, &applied_.command.command_N,
                       &applied_.command.fixture_force_N, &applied_.command.velocity_m_per_s}) {
    *v = ZeroDof(dof);
  }
  applied_.law_input = &input_;
  applied_.passivity = &passivity_.state();
  applied_.passivity_mode = passivity_.config().mode;
  applied_.reaction = reaction_.reaction();
  for (int g = 0; g < 4; ++g) gains_from_[g] = gains_to_[g] = gains_now_[g] = ZeroDof(dof);
  slew_normal_ = plane_normal_ = ZeroDof(dof);
}

void Coupling::RampGains(const DofVector& kp_N_per_m, const DofVector& kd_Ns_per_m, const DofVector& kv_Ns_per_m,
                         const DofVector& kf, double ramp_s) noexcept {
  const control::ThreeChannelLaw::Config& c = law_.config();
  gains_from_[0] = c.kp_N_per_m;
  gains_from_[1] = c.kd_Ns_per_m;
  gains_from_[2] = c.kv_Ns_per_m;
  gains_from_[3] = c.kf;
  gains_to_[0] = kp_N_per_m;
  gains_to_[1] = kd_Ns_per_m;
  gains_to_[2] = kv_Ns_per_m;
  gains_to_[3] = kf;
  gains_ramp_s_ = ramp_s > 0.0 ? ramp_s : 0.0;
  gains_elapsed_s_ = 0.0;
  gains_ramping_ = true;
}

void Coupling::MovePlane(int index, const DofVector& normal, double offset_m, double offset_rate_m_per_s,
                         double normal_rate_rad_per_s) noexcept {
  if (index < 0 || index >= law_.fixture().config().plane_count || normal.size() != config_.process.dof) return;
  slew_plane_ = index;
  slew_normal_ = normal;
  slew_offset_m_ = offset_m;
  slew_offset_rate_ = offset_rate_m_per_s;
  slew_normal_rate_ = normal_rate_rad_per_s;
  slewing_ = true;
}

void Coupling::StepRamps(double period_s) noexcept {
  if (ramping_) {
    ramp_elapsed_s_ += period_s;
    const double u = ramp_s_ > 0.0 ? std::min(ramp_elapsed_s_ / ramp_s_, 1.0) : 1.0;
    law_.SetFixtureStiffness(ramp_from_N_per_m_ + u * (ramp_to_N_per_m_ - ramp_from_N_per_m_));
    ramping_ = u < 1.0;
  }
  if (gains_ramping_) {
    gains_elapsed_s_ += period_s;
    const double u = gains_ramp_s_ > 0.0 ? std::min(gains_elapsed_s_ / gains_ramp_s_, 1.0) : 1.0;
    for (int g = 0; g < 4; ++g) gains_now_[g] = gains_from_[g] + u * (gains_to_[g] - gains_from_[g]);
    if (u >= 1.0) {
      for (int g = 0; g < 4; ++g) gains_now_[g] = gains_to_[g];  // exactly the target at the end
    }
    law_.SetGains(gains_now_[0], gains_now_[1], gains_now_[2], gains_now_[3]);
    gains_ramping_ = u < 1.0;
  }
  if (slewing_) StepPlane(period_s);
}

void Coupling::StepPlane(double period_s) noexcept {
  // Offset: toward the target by at most rate · period. Normal: along the great circle from the current normal to
  // the target by at most rate · period (rad). With a still device the fixture force K·d·n then changes per cycle by
  // at most K·period·(offset rate + normal rate·(|x| + d)) (eq. 7: F = K·d, d = n·x - offset).
  const control::FixturePlane& now = law_.fixture().config().planes[static_cast<std::size_t>(slew_plane_)];
  const double max_offset_step = slew_offset_rate_ * period_s;
  const double offset_step = std::clamp(slew_offset_m_ - now.offset_m, -max_offset_step, max_offset_step);
  const double offset =
      std::abs(slew_offset_m_ - now.offset_m) <= max_offset_step ? slew_offset_m_ : now.offset_m + offset_step;
  const double max_angle = slew_normal_rate_ * period_s;
  const double cosine = std::clamp(now.normal.dot(slew_normal_), -1.0, 1.0);
  const double angle = std::acos(cosine);
  bool normal_done = true;
  if (angle <= max_angle) {
    plane_normal_ = slew_normal_;
  } else {
    // The unit direction in the plane of the two normals, orthogonal to the current one; for an opposite target
    // (no such plane) the axis along which the current normal is smallest, made orthogonal.
    plane_normal_ = slew_normal_ - cosine * now.normal;
    if (plane_normal_.norm() < 1e-9) {
      int axis = 0;
      now.normal.cwiseAbs().minCoeff(&axis);
      plane_normal_.setZero();
      plane_normal_[axis] = 1.0;
      plane_normal_ -= now.normal.dot(plane_normal_) * now.normal;
    }
    if (plane_normal_.norm() < 1e-9) plane_normal_ = slew_normal_;  // 1 DOF (refused by the node before)
    plane_normal_ /= plane_normal_.norm();
    plane_normal_ = std::cos(max_angle) * now.normal + std::sin(max_angle) * plane_normal_;
    plane_normal_ /= plane_normal_.norm();
    normal_done = false;
  }
  max_plane_offset_step_m_ = std::max(max_plane_offset_step_m_, std::abs(offset - now.offset_m));
  max_plane_normal_step_rad_ =
      std::max(max_plane_normal_step_rad_, std::acos(std::clamp(plane_normal_.dot(now.normal), -1.0, 1.0)));
  law_.SetFixturePlane(slew_plane_, plane_normal_, offset);
  slewing_ = !(normal_done && offset == slew_offset_m_);
}

const Applied& Coupling::Step(const Sensed& sensed, const PeerView& peer, std::uint64_t cycle, double t_s,
                              double period_s) noexcept {
  Engage(sensed, peer, cycle, t_s);
  cycle_ = cycle;
  StepRamps(period_s);
  PrepareInput(*sensed.reading, peer, t_s, period_s);
  applied_.law = law_.Step(input_, period_s);
  applied_.nonfinite = applied_.law.status == control::ThreeChannelLaw::StepStatus::kNonFiniteInput;
  EngagementMachine::Transition& tr = applied_.transition;
  if (applied_.nonfinite)
    tr.coupling_lost = engagement_.Update(Outage::kNonFiniteInput, false, t_s).coupling_lost || tr.coupling_lost;
  if (tr.coupling_lost)
    events_.Push({Event::Kind::kCouplingLost, cycle, static_cast<double>(engagement_.last_outage())});
  if (tr.aligning_started) events_.Push({Event::Kind::kAligning, cycle, 0.0});
  if (tr.engaged) events_.Push({Event::Kind::kEngaged, cycle, engagement_.aligning_max_s()});
  const Path path = PathOf(sensed);
  Shape(path, t_s, period_s);
  Passivate(path, peer, period_s);
  Track(path, period_s);
  state_.last_velocity = applied_.law.velocity_m_per_s;
  applied_.engagement = engagement_.state();
  return applied_;
}

void Coupling::Engage(const Sensed& sensed, const PeerView& peer, std::uint64_t cycle, double t_s) noexcept {
  // The clutch (docs/clutch.md): the lowest-precedence blocker, so a fault or a lost
  // peer still chooses the reaction; the clutch's own command applies only when nothing else is wrong.
  std::uint8_t sources = 0;
  if (sensed.reading->clutch_pressed) sources |= kClutchDevice;
  if (command_clutch_) sources |= kClutchCommand;
  if (peer.have_peer && peer.fresh && (peer.sample->flags & proto::kFlagClutched) != 0) sources |= kClutchPeer;
  if (sources != 0 && state_.clutch_sources == 0) {
    ++state_.clutch_presses;
    events_.Push({Event::Kind::kClutchPressed, cycle, static_cast<double>(sources)});
  } else if (sources == 0 && state_.clutch_sources != 0) {
    events_.Push({Event::Kind::kClutchReleased, cycle, 0.0});
  }
  state_.clutch_sources = sources;
  const bool master = config_.process.role == Role::kMaster;
  if (sources != 0 && master) state_.index_pending = true;
  Outage blocker = Blocker(sensed.local_faults, peer);
  if (blocker == Outage::kNone && sources != 0) blocker = Outage::kClutch;
  clutch_blocked_ = blocker == Outage::kClutch;
  clutch_path_ = clutch_blocked_ && (master || config_.can_push);
  applied_.clutch_sources = sources;
  // The master's flag also carries the peer's clutch and a pending re-index: the slave holds until the master's
  // samples carry the re-indexed position. The slave's carries only its own (no latch between the two).
  const std::uint8_t own = sources & static_cast<std::uint8_t>(kClutchDevice | kClutchCommand);
  applied_.clutch_flag = master ? (sources != 0 || state_.index_pending) : own != 0;
  applied_.transition = engagement_.Update(blocker, state_.aligned_verdict, t_s);
}

void Coupling::Reindex(const device::Reading& reading, std::uint64_t cycle) noexcept {
  // Master, coupling resumes after a clutch: the offset that puts the (indexed) master where the slave is, in the
  // master's frame (the slave's position · peer_position_scale). The slave's reference is then its own position;
  // scaled axes stay scaled (the offset is added before the law and the wire, the motion keeps its scale).
  state_.index_pending = false;
  ++state_.reindexes;
  const int dof = config_.process.dof;
  double largest = 0.0;
  for (int i = 0; i < dof; ++i) {
    const double offset = applied_.peer_local_m[i] - reading.position_m[i];
    hold_N_[i] = offset - state_.index_offset_m[i];  // the shift of the law's frame (hold_N_ as scratch)
    state_.index_offset_m[i] = offset;
    largest = std::max(largest, std::abs(offset));
  }
  law_.ShiftPosition(hold_N_);
  input_.position_m = reading.position_m + state_.index_offset_m;
  events_.Push({Event::Kind::kReindexed, cycle, largest});
}

Coupling::Path Coupling::PathOf(const Sensed& sensed) const noexcept {
  if (sensed.local_faults != device::kFaultNone) return Path::kDeviceFault;
  if (applied_.nonfinite) return Path::kNonFinite;
  if (!engagement_.coupling()) return clutch_path_ ? Path::kClutched : Path::kReaction;
  return engagement_.state() == EngagementState::kAligning ? Path::kAligning : Path::kEngaged;
}

void Coupling::PrepareInput(const device::Reading& reading, const PeerView& peer, double t_s,
                            double period_s) noexcept {
  const int dof = config_.process.dof;
  input_.position_m = reading.position_m + state_.index_offset_m;  // the offset is zero but on a re-indexed master
  input_.has_velocity = config_.measures_velocity;
  input_.velocity_m_per_s = reading.velocity_m_per_s;
  if (peer.have_peer) {
    CopyFromWire(peer.sample->position_m, dof, input_.peer_position_m);
    CopyFromWire(peer.sample->velocity_m_per_s, dof, input_.peer_velocity_m_per_s);
    CopyFromWire(peer.sample->force_N, dof, input_.peer_force_N);
  }
  applied_.peer_local_m = config_.process.law.peer_position_scale * input_.peer_position_m;
  if (!engagement_.coupling()) {
    if (clutch_path_) {
      // Clutched: a slave holds where it is (the hold reaction); the master runs the law without a peer (its
      // fixture stays), the coupling force fades at the bounded rate (ShapeClutched).
      state_.reaction_latched = false;
      if (config_.process.role == Role::kMaster) {
        input_.peer_valid = false;
        return;
      }
      if (!state_.clutch_latched) {
        clutch_hold_.Latch(input_.position_m, state_.last_velocity, limiter_.last_N(), t_s);
        state_.clutch_latched = true;
      }
      clutch_hold_.PrepareInput(input_, period_s);
      return;
    }
    state_.clutch_latched = false;
    if (!state_.reaction_latched) {
      reaction_.Latch(input_.position_m, state_.last_velocity, limiter_.last_N(), t_s);
      state_.reaction_latched = true;
    }
    reaction_.PrepareInput(input_, period_s);
    return;
  }
  state_.reaction_latched = false;
  state_.clutch_latched = false;
  input_.peer_valid = true;
  if (applied_.transition.aligning_started) {
    if (state_.index_pending) Reindex(reading, cycle_);
    aligner_.Start(input_.position_m, t_s);
    state_.aligned_verdict = false;
    state_.last_reference_m = input_.position_m;
  }
  if (engagement_.state() == EngagementState::kAligning) {
    Align(reading, t_s, period_s);
    return;
  }
  if (applied_.transition.engaged) {
    state_.max_reference_step_m =
        std::max(state_.max_reference_step_m, MaxAbs(applied_.peer_local_m - state_.last_reference_m));
  }
  state_.last_reference_m = applied_.peer_local_m;
}

void Coupling::Align(const device::Reading& /*reading*/, double t_s, double period_s) noexcept {
  // The law sees a peer that starts where this device is and moves to the real one at bounded speed.
  const double scale = config_.process.law.peer_position_scale;
  const DofVector& ref = aligner_.Step(applied_.peer_local_m, t_s, period_s);
  state_.max_reference_step_m = std::max(state_.max_reference_step_m, aligner_.last_step_m());
  input_.peer_position_m = ref / scale;
  // Once caught up the reference is the peer: its velocity is the peer's (no K_d step at the switch).
  if (!aligner_.caught_up()) input_.peer_velocity_m_per_s = aligner_.reference_velocity_m_per_s() / scale;
  input_.peer_force_N *= aligner_.ramp();
  state_.last_reference_m = ref;
}

void Coupling::Shape(Path path, double t_s, double period_s) noexcept {
  const control::ThreeChannelLaw::Output& out = applied_.law;
  control::ThreeChannelLaw::Output& cmd = applied_.command;
  cmd.velocity_m_per_s = out.velocity_m_per_s;
  cmd.fixture_penetration_m = out.fixture_penetration_m;
  cmd.status = out.status;
  cmd.fixture_force_N = out.fixture_force_N;
  applied_.safe = false;
  switch (path) {
    case Path::kDeviceFault:
      applied_.safe = true;
      break;
    case Path::kNonFinite:
      cmd.command_N = out.command_N;  // the law's zero command
      cmd.fixture_force_N.setZero();
      break;
    case Path::kAligning: {
      // The coupling part ramps in at a bounded rate; the fixture's share is never limited.
      const double max_force_N = config_.process.law.max_force_N;
      const DofVector before = limiter_.last_N();
      cmd.command_N = limiter_.Limit(out.command_N - out.fixture_force_N,
                                     config_.process.engagement.max_force_rate_N_per_s, period_s) +
                      out.fixture_force_N;
      if (max_force_N > 0.0) cmd.command_N = cmd.command_N.cwiseMax(-max_force_N).cwiseMin(max_force_N);
      state_.max_aligning_force_rate =
          std::max(state_.max_aligning_force_rate, MaxAbs(limiter_.last_N() - before) / period_s);
      state_.aligned_verdict = aligner_.aligned() && !limiter_.clipped();
      break;
    }
    case Path::kEngaged:
      cmd.command_N = out.command_N;
      break;
    case Path::kClutched:
      ShapeClutched(t_s, period_s);
      break;
    case Path::kReaction: {
      applied_.safe = !reaction_.Command(out, t_s, cmd.command_N);
      const Reaction r = reaction_.reaction();
      const bool with_fixture = r == Reaction::kHold || r == Reaction::kDecelerate || r == Reaction::kFade;
      if (!with_fixture) cmd.fixture_force_N.setZero();
      break;
    }
  }
  if (applied_.safe) {
    cmd.command_N = zero_;
    cmd.fixture_force_N.setZero();
  }
}

void Coupling::ShapeClutched(double t_s, double period_s) noexcept {
  // The coupling part moves to the clutch's target (slave: the hold's force; master: none) at the bounded force
  // rate, so neither the press nor a release mid-fade steps the force; the fixture's share is never limited.
  const control::ThreeChannelLaw::Output& out = applied_.law;
  control::ThreeChannelLaw::Output& cmd = applied_.command;
  if (config_.process.role == Role::kMaster) {
    hold_N_.setZero();
  } else {
    (void)clutch_hold_.Command(out, t_s, hold_N_);  // hold never asks for the safe state
    hold_N_ -= out.fixture_force_N;
  }
  const DofVector before = limiter_.last_N();
  cmd.command_N =
      limiter_.Limit(hold_N_, config_.process.engagement.max_force_rate_N_per_s, period_s) + out.fixture_force_N;
  const double max_force_N = config_.process.law.max_force_N;
  if (max_force_N > 0.0) cmd.command_N = cmd.command_N.cwiseMax(-max_force_N).cwiseMin(max_force_N);
  state_.max_clutch_force_rate = std::max(state_.max_clutch_force_rate, MaxAbs(limiter_.last_N() - before) / period_s);
}

void Coupling::Passivate(Path path, const PeerView& peer, double period_s) noexcept {
  // The port sees the command the device gets: after the limiter, the reaction and the safe state. Where that
  // command must stay what it is (the safe state, zero_force), the controller only observes.
  passivity_input_.force_N = applied_.command.command_N;
  passivity_input_.velocity_m_per_s = applied_.law.velocity_m_per_s;
  passivity_input_.may_act =
      !applied_.safe && !(path == Path::kReaction && reaction_.reaction() == Reaction::kZeroForce);
  passivity_input_.peer_energy_valid = peer.have_peer && peer.sample->has_energy;
  if (passivity_input_.peer_energy_valid) {
    CopyFromWire(peer.sample->input_energy_J, config_.process.dof, passivity_input_.peer_input_energy_J);
  } else if (peer.have_peer && passivity_.config().mode == control::PassivityMode::kEnergyExchange) {
    ++state_.passivity_peer_without_energy;
  }
  const control::PassivityController::Output pc = passivity_.Step(passivity_input_, period_s);
  applied_.command.command_N = pc.force_N;
  applied_.damping_Ns_per_m = pc.damping_Ns_per_m;
}

void Coupling::Track(Path path, double period_s) noexcept {
  const DofVector& applied_N = applied_.command.command_N;
  switch (path) {
    case Path::kEngaged: {
      const DofVector coupling = applied_N - applied_.law.fixture_force_N;
      if (applied_.transition.engaged) {
        state_.max_aligning_force_rate =
            std::max(state_.max_aligning_force_rate, MaxAbs(coupling - limiter_.last_N()) / period_s);
      }
      limiter_.Track(coupling);
      break;
    }
    case Path::kReaction:
      limiter_.Track(applied_N - applied_.command.fixture_force_N);
      break;
    case Path::kDeviceFault:
      limiter_.Track(applied_N);
      break;
    case Path::kAligning:  // the limiter holds what it let through
    case Path::kClutched:
    case Path::kNonFinite:
      break;
  }
}

}  // namespace teleop::node
