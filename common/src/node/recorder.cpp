#include "recorder.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace teleop::node {

namespace {

void CopyToRecord(const DofVector& v, double (&out)[kMaxDof]) noexcept {
  for (int i = 0; i < kMaxDof; ++i) out[i] = i < v.size() ? v[i] : 0.0;
}

/// Bit of an outage in a mask of active faults.
constexpr std::uint32_t Bit(Outage o) noexcept { return 1u << static_cast<unsigned>(o); }

}  // namespace

Recorder::Recorder(const Config& config, SinkSet& sinks, EventLog& events)
    : config_(config), sinks_(sinks), events_(events) {}

void Recorder::Step(const Sensed& sensed, const PeerView& peer, const Applied& applied,
                    const CycleFacts& facts) noexcept {
  Count(sensed, peer, applied, facts);
  RaiseEvents(sensed, applied, facts);
  CycleRecord record;
  record.telemetry = &Row(sensed, peer, applied, facts);
  record.engagement = applied.engagement;
  record.stopping = facts.stopping;
  record.local_fault = sensed.local_faults != device::kFaultNone || applied.nonfinite;
  record.peer_fault = peer.peer_fault;
  record.have_peer = peer.have_peer;
  record.peer_shutdown = peer.shutdown;
  record.peer_fresh = peer.fresh && !peer.link_faulted;
  record.clutch = applied.clutch_sources;
  record.device_faults = sensed.reading->faults;
  record.device_warnings = sensed.reading->warnings;
  record.overruns = facts.overruns;
  record.watchdog_trips = facts.watchdog_trips;
  record.link = facts.link;
  // The law's own position (a re-indexed master's reading + its index offset): the offset is not an error.
  record.tracking_error_m =
      peer.usable
          ? (applied.law_input.position_m - config_.peer_position_scale * applied.law_input.peer_position_m).norm()
          : 0.0;
  sinks_.OnCycle(record);  // every cycle: the fault ring; decimated by the CSV and the DDS sinks
  TriggerFaults(sensed, peer, applied, facts);
}

void Recorder::Count(const Sensed& sensed, const PeerView& peer, const Applied& applied,
                     const CycleFacts& facts) noexcept {
  State& s = state_;
  if (sensed.local_faults != device::kFaultNone) ++s.device_fault_cycles;
  if (applied.law.status == control::ThreeChannelLaw::StepStatus::kSaturated) ++s.saturated_cycles;
  if (peer.usable) ++s.cycles_with_peer;
  if (applied.engagement == EngagementState::kEngaged) {
    ++s.engaged_cycles;
    const double e = (applied.law_input.position_m - applied.peer_local_m).norm();  // index offset excluded
    s.tracking_sq_sum += e * e;
    s.tracking_max = std::max(s.tracking_max, e);
  }
  s.max_penetration = std::max(s.max_penetration, applied.law.fixture_penetration_m);
  if (facts.coupled_trigger_timeout) ++s.coupled_trigger_timeouts;
  const std::uint32_t warnings = sensed.reading->warnings;
  if (warnings != device::kWarningNone) ++s.device_warning_cycles;
  s.device_warnings_seen |= warnings;
}

void Recorder::RaiseEvents(const Sensed& sensed, const Applied& applied, const CycleFacts& facts) noexcept {
  State& s = state_;
  const bool fault = sensed.local_faults != device::kFaultNone;
  if (fault && !s.device_faulted) {
    events_.Push({Event::Kind::kDeviceFault, facts.cycle, static_cast<double>(sensed.local_faults)});
  } else if (!fault && s.device_faulted) {
    events_.Push({Event::Kind::kDeviceFaultCleared, facts.cycle, 0.0});
  }
  s.device_faulted = fault;
  if (const std::uint32_t warnings = sensed.reading->warnings; warnings != s.device_warnings) {
    ++s.device_warning_changes;
    events_.Push({Event::Kind::kDeviceWarning, facts.cycle, static_cast<double>(warnings)});
    s.device_warnings = warnings;
  }
  if (applied.nonfinite) {
    if (s.nonfinite_inputs == 0) events_.Push({Event::Kind::kNonFiniteInput, facts.cycle, 0.0});
    ++s.nonfinite_inputs;
  }
  // Overruns are reported at most once a second so that a loaded machine does not flood the log.
  if (facts.overruns > s.reported_overruns &&
      (s.overrun_event_cycle == 0 || facts.cycle >= s.overrun_event_cycle + config_.rate)) {
    s.reported_overruns = facts.overruns;
    s.overrun_event_cycle = facts.cycle;
    events_.Push({Event::Kind::kOverrun, facts.cycle, static_cast<double>(s.reported_overruns)});
  }
}

const runtime::TelemetryRecord& Recorder::Row(const Sensed& sensed, const PeerView& peer, const Applied& applied,
                                              const CycleFacts& facts) noexcept {
  const device::Reading& reading = *sensed.reading;
  const control::ThreeChannelLaw::Output& out = applied.law;
  const control::ThreeChannelLaw::Input& input = applied.law_input;
  runtime::TelemetryRecord& r = row_;
  r = runtime::TelemetryRecord{};
  r.cycle = facts.cycle;
  r.time_s = facts.t_s;
  r.dof = config_.dof;
  CopyToRecord(reading.position_m, r.position_m);
  CopyToRecord(out.velocity_m_per_s, r.velocity_m_per_s);
  CopyToRecord(reading.force_N, r.force_sensor_N);
  CopyToRecord(applied.command.command_N, r.command_N);
  CopyToRecord(reading.rendered_force_N, r.rendered_force_N);
  CopyToRecord(out.fixture_force_N, r.fixture_force_N);
  CopyToRecord(applied.peer_local_m / config_.peer_position_scale, r.peer_position_m);
  CopyToRecord(input.peer_velocity_m_per_s, r.peer_velocity_m_per_s);
  CopyToRecord(input.peer_force_N, r.peer_force_N);
  for (int i = 0; i < config_.dof; ++i) {
    const auto k = static_cast<std::size_t>(i);
    if (!peer.have_peer) {
      // No peer sample held (before a session's first one): zeros, not the safe-state reaction's virtual peer.
      r.peer_position_m[i] = r.peer_velocity_m_per_s[i] = r.peer_force_N[i] = 0.0;
    } else if (applied.engagement != EngagementState::kEngaged) {
      // Not coupled: record what the peer sent, not the virtual peer of the aligning or the reaction.
      r.peer_velocity_m_per_s[i] = peer.sample->velocity_m_per_s[k];
      r.peer_force_N[i] = peer.sample->force_N[k];
    }
    r.passivity_observed_J[i] = applied.passivity.observed_J[k];
    r.passivity_damping_Ns_per_m[i] = i < applied.damping_Ns_per_m.size() ? applied.damping_Ns_per_m[i] : 0.0;
  }
  r.fixture_penetration_m = out.fixture_penetration_m;
  r.law_status = static_cast<int>(out.status);
  r.flags = facts.flags;
  r.rtt_s = peer.rtt_s;
  r.compute_s = static_cast<double>(runtime::MonotonicNowNs() - facts.cycle_start_mono_ns) * 1e-9;
  r.data_age_s =
      facts.data_age_ns >= 0 ? static_cast<double>(facts.data_age_ns) * 1e-9 : std::numeric_limits<double>::quiet_NaN();
  r.engagement = static_cast<int>(applied.engagement);
  r.device_warnings = reading.warnings;
  r.clutch = applied.clutch_sources;
  r.fixture_stiffness_N_per_m = applied.fixture_stiffness_N_per_m;
  r.fixture_limit_N_per_m = facts.fixture_limit_N_per_m;
  r.joints = config_.joints;
  CopyToRecord(reading.joint_position_rad, r.joint_position_rad);
  CopyToRecord(reading.joint_torque_Nm, r.joint_torque_Nm);
  return r;
}

void Recorder::TriggerFaults(const Sensed& sensed, const PeerView& peer, const Applied& applied,
                             const CycleFacts& facts) noexcept {
  std::uint32_t present = 0;
  if (sensed.local_faults != device::kFaultNone) present |= Bit(Outage::kDeviceFault);
  if (applied.nonfinite) present |= Bit(Outage::kNonFiniteInput);
  if (peer.link_faulted) present |= Bit(Outage::kLinkFault);
  if (peer.have_peer && !peer.fresh) present |= Bit(Outage::kPeerLost);
  if (peer.latency_gate_closed) present |= Bit(Outage::kLatency);
  const std::uint32_t started = present & ~state_.active_faults;
  state_.active_faults = present;
  if (started == 0) return;
  const double age = peer.have_peer ? facts.t_s - peer.last_feed_s : std::numeric_limits<double>::quiet_NaN();
  for (const Outage kind :
       {Outage::kDeviceFault, Outage::kNonFiniteInput, Outage::kLinkFault, Outage::kPeerLost, Outage::kLatency}) {
    if ((started & Bit(kind)) == 0) continue;
    FaultRecorder::Info info;
    info.kind = kind;
    info.cycle = facts.cycle;
    info.time_s = facts.t_s;
    info.reaction = applied.reaction;
    info.device_safe_state = applied.safe && applied.reaction != Reaction::kBrake;
    info.peer_sample_age_s = age;
    info.device_faults = sensed.local_faults;
    sinks_.OnFault(info);
  }
}

}  // namespace teleop::node
