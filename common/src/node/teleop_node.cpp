#include "teleop/node/teleop_node.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <limits>

#include "teleop/config/render_check.hpp"
#include "teleop/dds/bridge.hpp"  // DDS bridge (docs/dds.md)
#include "teleop/device/law_command.hpp"
#include "teleop/error.hpp"
#include "teleop/link/link_config.hpp"
#include "teleop/node/engagement.hpp"
#include "teleop/node/event_log.hpp"
#include "teleop/node/fault_recorder.hpp"
#include "teleop/node/reading_check.hpp"
#include "teleop/node/safe_reaction.hpp"
#include "teleop/runtime/data_age.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "teleop/runtime/telemetry.hpp"
#include "teleop/runtime/watchdog.hpp"
#include "teleop/transport/impaired_link.hpp"

namespace teleop::node {

namespace {

using runtime::MonotonicNowNs;

void CopyToWire(const DofVector& v, std::array<double, proto::kMaxWireDof>& out) noexcept {
  for (int i = 0; i < v.size(); ++i) out[static_cast<std::size_t>(i)] = v[i];
}

void CopyFromWire(const std::array<double, proto::kMaxWireDof>& in, int dof, DofVector& out) noexcept {
  out.resize(dof);
  for (int i = 0; i < dof; ++i) out[i] = in[static_cast<std::size_t>(i)];
}

void CopyToRecord(const DofVector& v, double (&out)[kMaxDof]) noexcept {
  for (int i = 0; i < kMaxDof; ++i) out[i] = i < v.size() ? v[i] : 0.0;
}

// ---- time-domain passivity (docs/stability.md): a config built in code may leave the controller's config unsized.
control::PassivityController::Config PassivityConfigOf(const config::ProcessConfig& cfg) {
  control::PassivityController::Config pc = cfg.passivity;
  pc.dof = cfg.dof;
  if (pc.max_damping_Ns_per_m.size() != cfg.dof) pc.max_damping_Ns_per_m = ZeroDof(cfg.dof);
  pc.max_force_N = cfg.law.max_force_N;
  return pc;
}

double MaxAbs(const DofVector& v) noexcept { return v.size() > 0 ? v.cwiseAbs().maxCoeff() : 0.0; }

/// Refuses, at start-up, a reaction the device cannot perform (safety.reaction).
void RequireReaction(const config::ProcessConfig& config, const device::Capabilities& caps, const std::string& name) {
  const Reaction r = config.safety.reaction;
  std::string problem;
  if (r == Reaction::kBrake && !caps.has_brake) {
    problem = "'brake' needs a device with a brake; device '" + name + "' has none (capabilities.has_brake)";
  } else if ((r == Reaction::kHold || r == Reaction::kDecelerate || r == Reaction::kDamping) && !caps.can_push()) {
    problem = std::string("'") + ToString(r) + "' needs an active actuator; device '" + name + "' renders " +
              device::ToString(caps.rendering) + " (use 'zero_force'" + (caps.has_brake ? " or 'brake')" : ")");
  }
  if (!problem.empty()) throw Error(config.source_path + ": key 'safety.reaction': " + problem);
}

/// Where fault records go: safety.fault_record_dir, else the telemetry CSV's directory, else the working directory.
std::string FaultRecordDir(const config::ProcessConfig& config) {
  if (!config.safety.fault_record_dir.empty()) return config.safety.fault_record_dir;
  if (!config.telemetry.csv_path.empty()) {
    const std::filesystem::path parent = std::filesystem::path(config.telemetry.csv_path).parent_path();
    if (!parent.empty()) return parent.string();
  }
  return ".";
}

/// Bit of an outage in a mask of active faults.
constexpr std::uint32_t Bit(Outage o) noexcept { return 1u << static_cast<unsigned>(o); }

}  // namespace

struct TeleopNode::Impl {
  Impl(const config::ProcessConfig& cfg, std::unique_ptr<device::Device> dev, std::unique_ptr<transport::Link> lnk)
      : config(cfg),
        device(std::move(dev)),
        link(std::move(lnk)),
        law(cfg.law),
        passivity(PassivityConfigOf(cfg)),  // time-domain passivity
        loop(cfg.loop),
        watchdog(cfg.link.timeout_ms * 1e-3),
        events(1024),
        aligner(cfg.engagement, cfg.dof),
        limiter(cfg.dof),
        reaction(cfg.safety, cfg.law),
        faults(static_cast<std::size_t>(cfg.safety.fault_record_cycles), cfg.dof, FaultRecordDir(cfg),
               ToString(cfg.role), cfg.safety.max_fault_records) {
    const int dof = config.dof;
    device->Configure();  // opens the bus; capabilities() is final after it
    config::RequireRenderable(config, device->capabilities(), device->name());
    RequireReaction(config, device->capabilities(), device->name());
    reading_check = std::make_unique<ReadingCheck>(config.safety, device->capabilities(), dof);
    command_N = ZeroDof(dof);
    peer_local_m = ZeroDof(dof);
    last_velocity = ZeroDof(dof);
    last_reference_m = ZeroDof(dof);
    reading.position_m = ZeroDof(dof);
    reading.velocity_m_per_s = ZeroDof(dof);
    reading.force_N = ZeroDof(dof);
    reading.rendered_force_N = ZeroDof(dof);
    command = device::Command::Force(ZeroDof(dof));
    input.position_m = ZeroDof(dof);
    input.velocity_m_per_s = ZeroDof(dof);
    input.peer_position_m = ZeroDof(dof);
    input.peer_velocity_m_per_s = ZeroDof(dof);
    input.peer_force_N = ZeroDof(dof);
    passivity_input.peer_input_energy_J = ZeroDof(dof);  // time-domain passivity
    passivity_damping = ZeroDof(dof);
    zero_command = ZeroDof(dof);
    applied.command_N = ZeroDof(dof);
    applied.fixture_force_N = ZeroDof(dof);
    applied.velocity_m_per_s = ZeroDof(dof);
    outgoing.sender = transport::ToSender(config.role);
    rate = static_cast<std::uint64_t>(config.loop.rate_hz);
    outgoing.dof = static_cast<std::uint8_t>(dof);
    if (!config.telemetry.csv_path.empty()) {
      telemetry = std::make_unique<runtime::TelemetryWriter>(
          config.telemetry.csv_path, static_cast<std::size_t>(config.telemetry.ring_capacity), dof);
    }
    // ---- DDS bridge (docs/dds.md): its own thread publishes; the cycle only copies into its ring.
    if (config.dds.enabled) {
      bridge = std::make_unique<dds::Bridge>(config.dds, config.role, config.loop.rate_hz);
      bridge_decimation = bridge->decimation();
      events.SetObserver(bridge.get());
    }
    // ---- end DDS bridge
    device->Activate();  // last: a failure above leaves the device configured but never rendering
    active = true;
  }

  ~Impl() {
    if (active) device->Deactivate();
  }

  /// What Receive() concluded about the peer this cycle.
  struct PeerState {
    bool fresh = false;         ///< A sample arrived within the watchdog timeout.
    bool link_faulted = false;  ///< The link reports a fault (CAN bus-off, ...).
    bool usable = false;        ///< Fresh, link fine, peer neither shutting down nor faulted: couple.
    bool new_session = false;   ///< The link started a new session this cycle.
  };

  void Cycle(std::uint64_t cycle, double period_s, std::int64_t now_ns) noexcept;
  void Sense(double period_s) noexcept;
  PeerState Receive(std::uint64_t cycle, std::int64_t now_ns, double t_s) noexcept;
  Outage Blocker(const PeerState& peer_state) const noexcept;
  control::ThreeChannelLaw::Output Control(const EngagementMachine::Transition& tr, double t_s,
                                           double period_s) noexcept;
  /// Time-domain passivity: the law's command through the port's passivity controller (docs/stability.md).
  void Passivate(control::ThreeChannelLaw::Output& out, double period_s) noexcept;
  /// Returns whether the device was put into its safe state (device fault, brake) instead of commanded.
  bool Actuate(const control::ThreeChannelLaw::Output& out, std::uint64_t cycle, double t_s, double period_s) noexcept;
  std::uint8_t Transmit(const control::ThreeChannelLaw::Output& out, const PeerState& peer_state,
                        std::int64_t now_ns) noexcept;
  void Record(const control::ThreeChannelLaw::Output& out, const PeerState& peer_state, bool safe, std::uint8_t flags,
              std::uint64_t cycle, std::int64_t now_ns, double t_s) noexcept;
  void RecordFaults(const PeerState& peer_state, bool safe, std::uint64_t cycle, double t_s) noexcept;
  void PushBridgeState(const runtime::TelemetryRecord& record, const control::ThreeChannelLaw::Output& out,
                       const PeerState& peer_state, bool fault) noexcept;  // DDS bridge
  RunSummary Summarize(double wall_s);
  std::int64_t Now() const noexcept { return stepped_clock ? stepped_now_ns : MonotonicNowNs(); }

  config::ProcessConfig config;
  std::unique_ptr<device::Device> device;
  std::unique_ptr<transport::Link> link;
  control::ThreeChannelLaw law;
  control::PassivityController passivity;  ///< Time-domain passivity (docs/stability.md); off = observe only.
  runtime::PeriodicLoop loop;
  runtime::LinkWatchdog watchdog;
  std::unique_ptr<dds::Bridge> bridge;  ///< DDS bridge, or null. Declared before `events`: outlives its observer.
  std::uint64_t bridge_decimation = 1;
  EventLog events;
  std::unique_ptr<runtime::TelemetryWriter> telemetry;

  // Engagement and safe states (teleop/node/engagement.hpp, safe_reaction.hpp, fault_recorder.hpp).
  EngagementMachine engagement;
  Aligner aligner;
  ForceRateLimiter limiter;  ///< The coupling part of the command while aligning; tracks it otherwise.
  SafeReaction reaction;
  FaultRecorder faults;
  std::unique_ptr<ReadingCheck> reading_check;

  // Preallocated cycle state.
  device::Reading reading;
  device::Command command;
  control::ThreeChannelLaw::Input input;
  control::PassivityController::Input passivity_input;
  DofVector passivity_damping;
  std::uint64_t passivity_peer_without_energy = 0;  ///< energy_exchange: samples from the peer without the block.
  control::ThreeChannelLaw::Output applied;         ///< What was commanded (law, aligning limit or reaction).
  DofVector zero_command;
  DofVector command_N;
  DofVector peer_local_m;      ///< The peer's position in the local frame.
  DofVector last_velocity;     ///< The law's velocity of the previous cycle (for the reaction's latch).
  DofVector last_reference_m;  ///< The coupling reference of the previous cycle (local frame).
  proto::SampleMessage incoming{};
  proto::SampleMessage peer{};
  proto::SampleMessage outgoing{};
  bool active = false;  ///< Between Device::Activate and Device::Deactivate.
  bool have_peer = false;
  bool peer_was_valid = false;
  bool peer_shutdown = false;
  bool device_faulted = false;
  bool reaction_latched = false;
  bool aligned_verdict = false;  ///< Aligner reached the peer and the limiter did not clip (previous cycle).
  bool latency_gate_closed = false;
  bool stepped_clock = false;
  std::int64_t cycle_start_mono_ns = 0;
  std::int64_t stepped_now_ns = 0;
  std::uint32_t local_faults = 0;   ///< This cycle: device fault bits | the node's reading checks.
  std::uint32_t active_faults = 0;  ///< Bit(Outage) of the recorded faults present last cycle.
  bool nonfinite = false;
  bool just_engaged = false;
  std::uint64_t session_epoch = 0;
  std::int64_t start_ns = 0;
  std::int64_t peer_rx_ns = 0;            ///< When the medium received `peer` (kernel timestamp on UDP), loop clock.
  std::int64_t peer_clock_offset_ns = 0;  ///< Peer clock − ours, from the newest round trip (valid: have_offset).
  bool have_offset = false;
  std::int64_t law_start_ns = 0;  ///< When this cycle's law ran (for the data age).
  std::uint32_t sequence = 0;
  std::uint8_t last_flags = 0;

  // Run statistics.
  runtime::LatencyHistogram rtt_ns;
  runtime::DataAgeTracker
      data_age;  ///< Age of the peer sample the law uses (docs/performance.md, "Round trip and data age").
  std::uint64_t coupled_trigger_timeouts = 0;  ///< Triggered cycles that timed out while the peer was fresh.
  std::uint64_t stepped_cycles = 0;
  std::uint64_t cycles_with_peer = 0;
  std::uint64_t engaged_cycles = 0;
  std::uint64_t device_fault_cycles = 0;
  std::uint64_t saturated_cycles = 0;
  std::uint64_t nonfinite_inputs = 0;
  std::uint64_t reported_overruns = 0;
  std::uint64_t overrun_event_cycle = 0;
  std::uint64_t rate = 1000;  ///< Cycles per second, for rate-limiting events.
  double tracking_sq_sum = 0.0;
  double tracking_max = 0.0;
  double max_penetration = 0.0;
  double max_reference_step_m = 0.0;     ///< Largest one-cycle jump of the coupling reference while (re)engaging.
  double max_aligning_force_rate = 0.0;  ///< Largest |Δ coupling force| / period while aligning and at engagement.
  std::uint64_t latency_gate_trips = 0;
  std::uint64_t new_sessions = 0;
  std::uint64_t telemetry_records = 0;
  std::uint64_t dof_mismatches = 0;
  std::uint64_t link_fault_cycles = 0;
  double last_rtt_s = std::numeric_limits<double>::quiet_NaN();
  std::atomic<bool> stop_on_peer_shutdown{false};
  std::atomic<bool> stop_requested{false};
  bool finished = false;
};

// The cycle, stage by stage. Each stage is noexcept, allocation-free and lock-free.

void TeleopNode::Impl::Sense(double period_s) noexcept {
  device->Read(reading);
  local_faults = reading.faults | reading_check->Check(reading, period_s);
}

TeleopNode::Impl::PeerState TeleopNode::Impl::Receive(std::uint64_t cycle, std::int64_t now_ns, double t_s) noexcept {
  PeerState state;
  const bool got = link->Poll(incoming);
  // A new authenticated session is a new peer: forget the old one (the watchdog waits for the session's first
  // sample, CiA 301), and couple again only through aligning.
  if (const std::uint64_t epoch = link->session_epoch(); epoch != session_epoch) {
    session_epoch = epoch;
    state.new_session = true;
    ++new_sessions;
    watchdog.Reset();
    have_peer = false;
    peer_was_valid = false;
    peer_shutdown = false;
    last_flags = 0;
    events.Push({Event::Kind::kNewSession, cycle, static_cast<double>(epoch)});
  }
  if (got) {
    if (incoming.dof != config.dof) {
      // A peer configured for another DOF count: never applied; the watchdog expires and coupling stays off.
      ++dof_mismatches;
    } else {
      peer = incoming;
      // The medium's receive time (the kernel's timestamp on UDP) makes the round trip and the data age the
      // network's and the sample's, not the phase between two cycles; the cycle start where the link has none (and
      // on a stepped clock, whose time is not the kernel's).
      const std::int64_t received_ns = stepped_clock ? 0 : link->newest_receive_time_ns();
      peer_rx_ns = received_ns > 0 ? received_ns : now_ns;
      if (!have_peer) events.Push({Event::Kind::kPeerConnected, cycle, 0.0});
      have_peer = true;
      watchdog.Feed(t_s);
      const proto::RoundTripEstimate rtt = proto::EstimateRoundTrip(peer, static_cast<std::uint64_t>(peer_rx_ns));
      if (rtt.valid) {
        rtt_ns.Add(rtt.rtt_ns);
        last_rtt_s = static_cast<double>(rtt.rtt_ns) * 1e-9;
        peer_clock_offset_ns = rtt.offset_ns;
        have_offset = true;
        // Latency gate with 20 % hysteresis (engagement.max_rtt_ms; 0 = off).
        const double limit_s = config.engagement.max_rtt_ms * 1e-3;
        if (limit_s > 0.0 && !latency_gate_closed && last_rtt_s > limit_s) {
          latency_gate_closed = true;
          ++latency_gate_trips;
          events.Push({Event::Kind::kLatencyGate, cycle, last_rtt_s * 1e3});
        } else if (latency_gate_closed && last_rtt_s < 0.8 * limit_s) {
          latency_gate_closed = false;
        }
      }
      const std::int64_t sent_local_ns =
          have_offset ? static_cast<std::int64_t>(peer.sender_time_ns) - peer_clock_offset_ns : 0;
      data_age.OnNewSample(peer_rx_ns, sent_local_ns, loop.cycle_triggered());
      const bool shutdown = (peer.flags & proto::kFlagShutdown) != 0;
      if (shutdown && !peer_shutdown) {
        events.Push({Event::Kind::kPeerShutdown, cycle, 0.0});
        if (stop_on_peer_shutdown.load(std::memory_order_relaxed)) loop.Stop();
      }
      peer_shutdown = shutdown;
      if ((peer.flags & proto::kFlagFault) != 0 && (last_flags & proto::kFlagFault) == 0) {
        events.Push({Event::Kind::kPeerFault, cycle, 0.0});
      }
      last_flags = peer.flags;
    }
  }
  state.fresh = have_peer && watchdog.Fresh(t_s);
  state.link_faulted = link->faulted();  // e.g. CAN bus-off: decouple now, not after the watchdog timeout
  if (state.link_faulted) ++link_fault_cycles;
  state.usable = state.fresh && !state.link_faulted && !peer_shutdown && (peer.flags & proto::kFlagFault) == 0;
  if (have_peer && peer_was_valid && !state.fresh) events.Push({Event::Kind::kPeerLost, cycle, 0.0});
  if (have_peer && !peer_was_valid && state.fresh && cycle > 0 && watchdog.trips() > 0) {
    events.Push({Event::Kind::kPeerRecovered, cycle, 0.0});
  }
  peer_was_valid = state.fresh;
  return state;
}

Outage TeleopNode::Impl::Blocker(const PeerState& peer_state) const noexcept {
  if (local_faults != device::kFaultNone) return Outage::kDeviceFault;
  if (peer_state.new_session) return Outage::kNewSession;
  if (!have_peer) return Outage::kNoPeer;
  if (peer_state.link_faulted) return Outage::kLinkFault;
  if (!peer_state.fresh) return Outage::kPeerLost;
  if (peer_shutdown) return Outage::kPeerShutdown;
  if ((peer.flags & proto::kFlagFault) != 0) return Outage::kPeerFault;
  if (latency_gate_closed) return Outage::kLatency;
  return Outage::kNone;
}

control::ThreeChannelLaw::Output TeleopNode::Impl::Control(const EngagementMachine::Transition& tr, double t_s,
                                                           double period_s) noexcept {
  const int dof = config.dof;
  const double scale = config.law.peer_position_scale;
  input.position_m = reading.position_m;
  input.has_velocity = device->capabilities().measures_velocity;
  input.velocity_m_per_s = reading.velocity_m_per_s;
  if (have_peer) {
    CopyFromWire(peer.position_m, dof, input.peer_position_m);
    CopyFromWire(peer.velocity_m_per_s, dof, input.peer_velocity_m_per_s);
    CopyFromWire(peer.force_N, dof, input.peer_force_N);
  }
  peer_local_m = scale * input.peer_position_m;
  if (engagement.coupling()) {
    reaction_latched = false;
    input.peer_valid = true;
    if (tr.aligning_started) {
      aligner.Start(reading.position_m, t_s);
      aligned_verdict = false;
      last_reference_m = reading.position_m;
    }
    if (engagement.state() == EngagementState::kAligning) {
      // The law sees a peer that starts where this device is and moves to the real one at bounded speed.
      const DofVector& ref = aligner.Step(peer_local_m, t_s, period_s);
      max_reference_step_m = std::max(max_reference_step_m, aligner.last_step_m());
      input.peer_position_m = ref / scale;
      // Once caught up the reference is the peer: its velocity is the peer's (no K_d step at the switch).
      if (!aligner.caught_up()) input.peer_velocity_m_per_s = aligner.reference_velocity_m_per_s() / scale;
      input.peer_force_N *= aligner.ramp();
      last_reference_m = ref;
    } else {
      if (tr.engaged) max_reference_step_m = std::max(max_reference_step_m, MaxAbs(peer_local_m - last_reference_m));
      last_reference_m = peer_local_m;
    }
  } else {
    if (!reaction_latched) {
      reaction.Latch(reading.position_m, last_velocity, limiter.last_N(), t_s);
      reaction_latched = true;
    }
    reaction.PrepareInput(input, period_s);
  }
  law_start_ns = Now();
  control::ThreeChannelLaw::Output out = law.Step(input, period_s);
  Passivate(out, period_s);  // time-domain passivity: the command passes through the controller before FillCommand
  return out;
}

// ---- time-domain passivity (docs/stability.md)
void TeleopNode::Impl::Passivate(control::ThreeChannelLaw::Output& out, double period_s) noexcept {
  // On a device fault Actuate puts the device in its safe state instead: the port then sees no force.
  const bool device_fault = reading.faults != device::kFaultNone;
  passivity_input.force_N = device_fault ? zero_command : out.command_N;
  passivity_input.velocity_m_per_s = out.velocity_m_per_s;
  passivity_input.peer_energy_valid = have_peer && peer.has_energy;
  if (passivity_input.peer_energy_valid) {
    CopyFromWire(peer.input_energy_J, config.dof, passivity_input.peer_input_energy_J);
  } else if (have_peer && passivity.config().mode == control::PassivityMode::kEnergyExchange) {
    ++passivity_peer_without_energy;
  }
  const control::PassivityController::Output pc = passivity.Step(passivity_input, period_s);
  if (!device_fault) out.command_N = pc.force_N;
  passivity_damping = pc.damping_Ns_per_m;
}
// ---- end time-domain passivity

bool TeleopNode::Impl::Actuate(const control::ThreeChannelLaw::Output& out, std::uint64_t cycle, double t_s,
                               double period_s) noexcept {
  const bool fault = local_faults != device::kFaultNone;
  applied.velocity_m_per_s = out.velocity_m_per_s;
  applied.fixture_penetration_m = out.fixture_penetration_m;
  applied.status = out.status;
  applied.fixture_force_N = out.fixture_force_N;
  bool safe = false;
  if (fault) {
    ++device_fault_cycles;
    if (!device_faulted) events.Push({Event::Kind::kDeviceFault, cycle, static_cast<double>(local_faults)});
    safe = true;
  } else {
    if (device_faulted) events.Push({Event::Kind::kDeviceFaultCleared, cycle, 0.0});
    if (nonfinite) {
      command_N = out.command_N;  // the law's zero command
      applied.fixture_force_N.setZero();
    } else if (engagement.coupling()) {
      command_N = out.command_N;
      if (engagement.state() == EngagementState::kAligning) {
        // The coupling part ramps in at a bounded rate; the fixture's share is never limited.
        const DofVector before = limiter.last_N();
        command_N =
            limiter.Limit(out.command_N - out.fixture_force_N, config.engagement.max_force_rate_N_per_s, period_s) +
            out.fixture_force_N;
        if (config.law.max_force_N > 0.0) {
          command_N = command_N.cwiseMax(-config.law.max_force_N).cwiseMin(config.law.max_force_N);
        }
        max_aligning_force_rate = std::max(max_aligning_force_rate, MaxAbs(limiter.last_N() - before) / period_s);
        aligned_verdict = aligner.aligned() && !limiter.clipped();
      } else {
        const DofVector coupling = out.command_N - out.fixture_force_N;
        if (just_engaged) {
          max_aligning_force_rate = std::max(max_aligning_force_rate, MaxAbs(coupling - limiter.last_N()) / period_s);
        }
        limiter.Track(coupling);
      }
    } else {
      safe = !reaction.Command(out, t_s, command_N);
      const Reaction r = reaction.reaction();
      const bool with_fixture = r == Reaction::kHold || r == Reaction::kDecelerate || r == Reaction::kFade;
      if (!with_fixture) applied.fixture_force_N.setZero();
      limiter.Track(command_N - applied.fixture_force_N);
    }
  }
  if (safe) {
    device->SetSafe();
    command_N.setZero();
    applied.fixture_force_N.setZero();
    limiter.Track(command_N);
  } else {
    applied.command_N = command_N;
    device::FillCommand(applied, law.fixture(), input.position_m, command);
    device->Write(command);
  }
  applied.command_N = command_N;
  device_faulted = fault;
  device->Update(period_s);
  last_velocity = out.velocity_m_per_s;
  return safe;
}

std::uint8_t TeleopNode::Impl::Transmit(const control::ThreeChannelLaw::Output& out, const PeerState& peer_state,
                                        std::int64_t now_ns) noexcept {
  outgoing.sequence = sequence++;
  outgoing.echo_time_ns = have_peer ? peer.sender_time_ns : 0;
  std::uint8_t flags = proto::kFlagEnabled;
  if (local_faults != device::kFaultNone || nonfinite) flags |= proto::kFlagFault;
  if ((have_peer && !peer_state.fresh) || peer_state.link_faulted) flags |= proto::kFlagPeerLost;
  if (out.status == control::ThreeChannelLaw::StepStatus::kSaturated) flags |= proto::kFlagSaturated;
  if (out.fixture_penetration_m > 0.0) flags |= proto::kFlagInFixture;
  if (loop.stopping()) flags |= proto::kFlagShutdown;
  outgoing.flags = flags;
  if ((flags & proto::kFlagFault) != 0) {
    // The values are not to be used (the peer decouples on the flag), and a NaN or absurd reading would make the
    // sample unencodable or implausible and the flag would never arrive: send zeros with it.
    outgoing.position_m.fill(0.0);
    outgoing.velocity_m_per_s.fill(0.0);
    outgoing.force_N.fill(0.0);
  } else {
    CopyToWire(reading.position_m, outgoing.position_m);
    CopyToWire(out.velocity_m_per_s, outgoing.velocity_m_per_s);
    CopyToWire(reading.force_N, outgoing.force_N);
  }
  // Time-domain passivity, energy_exchange: this port's energies travel with the sample (the energy block).
  outgoing.has_energy = passivity.config().mode == control::PassivityMode::kEnergyExchange;
  if (outgoing.has_energy) {
    outgoing.input_energy_J = passivity.state().input_energy_J;
    outgoing.output_energy_J = passivity.state().output_energy_J;
  }
  // Send time and echo age taken right before the send call (docs/protocol.md, "Round-trip time").
  const std::int64_t send_ns = Now();
  outgoing.sender_time_ns = static_cast<std::uint64_t>(send_ns);
  outgoing.echo_age_ns =
      have_peer ? static_cast<std::uint32_t>(std::clamp<std::int64_t>(send_ns - peer_rx_ns, 0, 0xFFFFFFFF)) : 0;
  (void)now_ns;
  (void)link->Send(outgoing);  // a refused send is counted by the link
  return flags;
}

void TeleopNode::Impl::Record(const control::ThreeChannelLaw::Output& out, const PeerState& peer_state, bool safe,
                              std::uint8_t flags, std::uint64_t cycle, std::int64_t now_ns, double t_s) noexcept {
  if (out.status == control::ThreeChannelLaw::StepStatus::kSaturated) ++saturated_cycles;
  if (nonfinite) {
    if (nonfinite_inputs == 0) events.Push({Event::Kind::kNonFiniteInput, cycle, 0.0});
    ++nonfinite_inputs;
  }
  if (peer_state.usable) ++cycles_with_peer;
  if (engagement.state() == EngagementState::kEngaged) {
    ++engaged_cycles;
    const double e = (reading.position_m - peer_local_m).norm();
    tracking_sq_sum += e * e;
    tracking_max = std::max(tracking_max, e);
  }
  max_penetration = std::max(max_penetration, out.fixture_penetration_m);
  const std::int64_t age_ns = peer_state.usable ? data_age.ReceiveAgeNs(law_start_ns) : -1;
  data_age.OnCycle(law_start_ns, peer_state.usable);
  if (peer_state.usable && loop.triggered_mode() && !loop.cycle_triggered()) ++coupled_trigger_timeouts;
  // Overruns are reported at most once a second so that a loaded machine does not flood the log.
  if (loop.stats().overruns > reported_overruns && (overrun_event_cycle == 0 || cycle >= overrun_event_cycle + rate)) {
    reported_overruns = loop.stats().overruns;
    overrun_event_cycle = cycle;
    events.Push({Event::Kind::kOverrun, cycle, static_cast<double>(reported_overruns)});
  }
  // Every cycle into the fault recorder's ring; decimated to the CSV and the DDS bridge.
  runtime::TelemetryRecord r{};
  r.cycle = cycle;
  r.time_s = t_s;
  r.dof = config.dof;
  CopyToRecord(reading.position_m, r.position_m);
  CopyToRecord(out.velocity_m_per_s, r.velocity_m_per_s);
  CopyToRecord(reading.force_N, r.force_sensor_N);
  CopyToRecord(safe ? zero_command : applied.command_N, r.command_N);
  CopyToRecord(reading.rendered_force_N, r.rendered_force_N);
  CopyToRecord(out.fixture_force_N, r.fixture_force_N);
  CopyToRecord(peer_local_m / config.law.peer_position_scale, r.peer_position_m);
  CopyToRecord(input.peer_velocity_m_per_s, r.peer_velocity_m_per_s);
  CopyToRecord(input.peer_force_N, r.peer_force_N);
  if (!have_peer) {
    // No peer sample held (before a session's first one): zeros, not the safe-state reaction's virtual peer.
    for (int i = 0; i < config.dof; ++i) {
      r.peer_position_m[i] = 0.0;
      r.peer_velocity_m_per_s[i] = 0.0;
      r.peer_force_N[i] = 0.0;
    }
  } else if (engagement.state() != EngagementState::kEngaged) {
    // Not coupled: record what the peer sent, not the virtual peer of the aligning or the reaction.
    for (int i = 0; i < config.dof; ++i) {
      r.peer_velocity_m_per_s[i] = peer.velocity_m_per_s[static_cast<std::size_t>(i)];
      r.peer_force_N[i] = peer.force_N[static_cast<std::size_t>(i)];
    }
  }
  r.fixture_penetration_m = out.fixture_penetration_m;
  r.law_status = static_cast<int>(out.status);
  r.flags = flags;
  r.rtt_s = last_rtt_s;
  r.compute_s = static_cast<double>(MonotonicNowNs() - cycle_start_mono_ns) * 1e-9;
  r.data_age_s = age_ns >= 0 ? static_cast<double>(age_ns) * 1e-9 : std::numeric_limits<double>::quiet_NaN();
  r.engagement = static_cast<int>(engagement.state());
  for (int i = 0; i < config.dof; ++i) {  // time-domain passivity
    r.passivity_observed_J[i] = passivity.state().observed_J[static_cast<std::size_t>(i)];
    r.passivity_damping_Ns_per_m[i] = i < passivity_damping.size() ? passivity_damping[i] : 0.0;
  }
  faults.Record(r);
  const bool to_csv = telemetry && cycle % static_cast<std::uint64_t>(config.telemetry.decimation) == 0;
  const bool to_dds = bridge && cycle % bridge_decimation == 0;  // DDS bridge
  if (to_csv && telemetry->Push(r)) ++telemetry_records;
  if (to_dds) PushBridgeState(r, out, peer_state, local_faults != device::kFaultNone);  // DDS bridge
  (void)now_ns;
}

void TeleopNode::Impl::RecordFaults(const PeerState& peer_state, bool safe, std::uint64_t cycle, double t_s) noexcept {
  std::uint32_t present = 0;
  if (local_faults != device::kFaultNone) present |= Bit(Outage::kDeviceFault);
  if (nonfinite) present |= Bit(Outage::kNonFiniteInput);
  if (peer_state.link_faulted) present |= Bit(Outage::kLinkFault);
  if (have_peer && !peer_state.fresh) present |= Bit(Outage::kPeerLost);
  if (latency_gate_closed) present |= Bit(Outage::kLatency);
  const std::uint32_t started = present & ~active_faults;
  active_faults = present;
  if (started == 0) return;
  const double age = have_peer ? t_s - watchdog.last_feed_s() : std::numeric_limits<double>::quiet_NaN();
  for (const Outage kind :
       {Outage::kDeviceFault, Outage::kNonFiniteInput, Outage::kLinkFault, Outage::kPeerLost, Outage::kLatency}) {
    if ((started & Bit(kind)) == 0) continue;
    FaultRecorder::Info info;
    info.kind = kind;
    info.cycle = cycle;
    info.time_s = t_s;
    info.reaction = reaction.reaction();
    info.device_safe_state = safe && reaction.reaction() != Reaction::kBrake;
    info.peer_sample_age_s = age;
    info.device_faults = local_faults;
    faults.Trigger(info);
  }
}

// ---- DDS bridge (docs/dds.md): one copy into the bridge's lock-free ring; a full ring is counted by the bridge.
void TeleopNode::Impl::PushBridgeState(const runtime::TelemetryRecord& record,
                                       const control::ThreeChannelLaw::Output& out, const PeerState& peer_state,
                                       bool fault) noexcept {
  dds::BridgeSample sample;
  sample.record = record;
  dds::EngagementInputs in;
  in.stopping = loop.stopping();
  in.local_fault = fault || out.status == control::ThreeChannelLaw::StepStatus::kNonFiniteInput;
  in.peer_fault = (peer.flags & proto::kFlagFault) != 0;
  in.have_peer = have_peer;
  in.peer_shutdown = peer_shutdown;
  in.peer_fresh = peer_state.fresh && !peer_state.link_faulted;
  in.engaged = engagement.state() == EngagementState::kEngaged;
  sample.engagement = dds::EngagementOf(in);
  sample.device_faults = reading.faults;
  sample.overruns = loop.stats().overruns;
  sample.watchdog_trips = watchdog.trips();
  sample.link = link->counters();
  sample.tracking_error_m =
      peer_state.usable ? (reading.position_m - config.law.peer_position_scale * input.peer_position_m).norm() : 0.0;
  (void)bridge->PushState(sample);
}
// ---- end DDS bridge

void TeleopNode::Impl::Cycle(std::uint64_t cycle, double period_s, std::int64_t now_ns) noexcept {
  cycle_start_mono_ns = MonotonicNowNs();
  if (cycle == 0 || stepped_cycles == 0) start_ns = now_ns;
  ++stepped_cycles;
  const double t_s = static_cast<double>(now_ns - start_ns) * 1e-9;
  Sense(period_s);                                           // 1. device → reading, plausibility
  const PeerState peer_state = Receive(cycle, now_ns, t_s);  // 2. drain the link, keep the newest sample
  // 3. engagement: couple (aligning, engaged) or react (latched safe state)
  EngagementMachine::Transition tr = engagement.Update(Blocker(peer_state), aligned_verdict, t_s);
  just_engaged = tr.engaged;
  auto out = Control(tr, t_s, period_s);  // 4. the law (with the aligned or virtual peer)
  nonfinite = out.status == control::ThreeChannelLaw::StepStatus::kNonFiniteInput;
  if (nonfinite) {
    const EngagementMachine::Transition again = engagement.Update(Outage::kNonFiniteInput, false, t_s);
    tr.coupling_lost = tr.coupling_lost || again.coupling_lost;
  }
  if (tr.coupling_lost) events.Push({Event::Kind::kCouplingLost, cycle, static_cast<double>(engagement.last_outage())});
  if (tr.aligning_started) events.Push({Event::Kind::kAligning, cycle, 0.0});
  if (tr.engaged) events.Push({Event::Kind::kEngaged, cycle, engagement.aligning_max_s()});
  const bool safe = Actuate(out, cycle, t_s, period_s);          // 5. command (or safe state), Update
  const std::uint8_t flags = Transmit(out, peer_state, now_ns);  // 6. this cycle's sample, with the echo
  Record(out, peer_state, safe, flags, cycle, now_ns, t_s);      // 7. statistics, events, telemetry, fault ring
  RecordFaults(peer_state, safe, cycle, t_s);                    // 8. a fault that started: its record
}

TeleopNode::TeleopNode(const config::ProcessConfig& config, std::unique_ptr<device::Device> device,
                       std::unique_ptr<transport::Link> link)
    : impl_(std::make_unique<Impl>(config, std::move(device), std::move(link))) {}

TeleopNode::~TeleopNode() = default;

void TeleopNode::Step(std::uint64_t cycle, double period_s) noexcept {
  impl_->stepped_clock = false;
  impl_->Cycle(cycle, period_s, MonotonicNowNs());
}

void TeleopNode::Step(std::uint64_t cycle, double period_s, std::int64_t now_ns) noexcept {
  impl_->stepped_clock = true;
  impl_->stepped_now_ns = now_ns;
  impl_->Cycle(cycle, period_s, now_ns);
}

EngagementState TeleopNode::engagement() const noexcept { return impl_->engagement.state(); }

void TeleopNode::Stop() noexcept {
  impl_->stop_requested.store(true, std::memory_order_relaxed);
  impl_->loop.Stop();
}

RunSummary TeleopNode::Run() {
  Impl& s = *impl_;
  s.stop_on_peer_shutdown.store(true);
  spdlog::info("teleop-{}: {} DOF at {:.0f} Hz, device '{}', link {}, reaction when not coupled: {}",
               ToString(s.config.role), s.config.dof, s.config.loop.rate_hz, s.device->name(), s.link->Describe(),
               ToString(s.config.safety.reaction));
  const bool realtime = s.config.loop.fifo_priority > 0 && s.config.loop.lock_memory;
  if (!realtime) {
    spdlog::warn(
        "teleop-{}: running without real-time settings (realtime.fifo_priority {}, realtime.lock_memory {}): "
        "expect wake-up jitter several times that of a real-time loop (docs/performance.md)",
        ToString(s.config.role), s.config.loop.fifo_priority, s.config.loop.lock_memory);
  }
  // Phase-locked cycles: the slave's cycle starts when the master's sample arrives (the master is the clock).
  if (s.config.loop.sync == runtime::CycleSync::kTriggered && s.config.role == Role::kSlave) {
    s.loop.SetTrigger([&s](std::int64_t deadline_ns) { return s.link->WaitReadable(deadline_ns); });
  }
  const auto wall_start = std::chrono::steady_clock::now();
  s.loop.Run([&s](std::uint64_t cycle, double period_s) { s.Cycle(cycle, period_s, MonotonicNowNs()); });
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  // Tell the peer we are going, so it stops coupling without a watchdog fault; then hold the safe state.
  s.outgoing.flags = proto::kFlagShutdown;
  s.outgoing.sequence = s.sequence++;
  (void)s.link->Send(s.outgoing);
  return s.Summarize(wall_s);
}

RunSummary TeleopNode::Finish() { return impl_->Summarize(0.0); }

RunSummary TeleopNode::Impl::Summarize(double wall_s) {
  Impl& s = *this;
  if (s.active) {
    s.device->Deactivate();
    s.active = false;
  }
  RunSummary summary;
  summary.role = s.config.role;
  summary.rate_hz = s.config.loop.rate_hz;
  const auto& st = s.loop.stats();
  summary.cycles = std::max(st.cycles, s.stepped_cycles);
  summary.duration_s = wall_s;
  summary.achieved_rate_hz = wall_s > 0 ? static_cast<double>(st.cycles) / wall_s : 0.0;
  summary.overruns = st.overruns;
  summary.period_us = FromHistogram(st.period_ns, 1e3);
  summary.jitter_us = FromHistogram(st.jitter_ns, 1e3);
  summary.compute_us = FromHistogram(st.compute_ns, 1e3);
  summary.link = s.link->counters();
  summary.rtt_ms = FromHistogram(s.rtt_ns, 1e6);
  summary.sync = runtime::ToString(s.config.loop.sync);
  summary.triggered_cycles = st.triggered_cycles;
  summary.trigger_timeouts = st.trigger_timeouts;
  summary.trigger_timeouts_coupled = s.coupled_trigger_timeouts;
  summary.data_age_us = FromHistogram(s.data_age.receive_age_ns(), 1e3);
  summary.data_age_sender_us = FromHistogram(s.data_age.sender_age_ns(), 1e3);
  summary.data_age_cycles = s.data_age.age_cycles();
  summary.realtime_settings_applied = st.realtime_settings_applied;
  summary.cpu_dma_latency_held = st.cpu_dma_latency_held;
  summary.cycles_with_peer = s.cycles_with_peer;
  summary.watchdog_trips = s.watchdog.trips();
  summary.device_fault_cycles = s.device_fault_cycles;
  summary.nonfinite_inputs = s.nonfinite_inputs;
  summary.saturated_cycles = s.saturated_cycles;
  summary.tracking_error_rms_m =
      s.engaged_cycles > 0 ? std::sqrt(s.tracking_sq_sum / static_cast<double>(s.engaged_cycles)) : 0.0;
  summary.tracking_error_max_m = s.tracking_max;
  summary.fixture_max_penetration_m = s.max_penetration;
  if (s.telemetry) {
    s.telemetry->Stop();
    summary.telemetry_records = s.telemetry_records;
    summary.telemetry_dropped = s.telemetry->dropped();
  }
  summary.dof_mismatches = s.dof_mismatches;
  summary.link_fault_cycles = s.link_fault_cycles;
  summary.link_detail = s.link->Summary();
  if (const auto* emulation = transport::EmulationCountersOf(*s.link)) summary.link_emulation = *emulation;
  summary.link_security = transport::ToString(s.config.link.security.mode);
  summary.passivity_mode = control::ToString(s.passivity.config().mode);  // time-domain passivity
  summary.passivity_cycles = s.passivity.state().acting_steps;
  summary.passivity_dissipated_J = s.passivity.total_dissipated_J();
  summary.passivity_min_observed_J = s.passivity.state().min_observed_J;
  summary.passivity_peer_without_energy = s.passivity_peer_without_energy;
  if (s.passivity_peer_without_energy > 0) {
    spdlog::error(
        "passivity energy_exchange: {} samples from the peer carried no energy block, so this side could "
        "give out nothing: set passivity.mode: energy_exchange on both processes",
        s.passivity_peer_without_energy);
  }
  summary.stop_reason = s.stop_requested.load() ? "signal" : (s.peer_shutdown ? "peer shutdown" : "duration");
  // Engagement and faults.
  EngagementSummary& e = summary.engagement;
  e.reaction = ToString(s.config.safety.reaction);
  e.final_state = ToString(s.engagement.state());
  e.times_engaged = s.engagement.engagements();
  e.couplings_lost = s.engagement.couplings_lost();
  e.engaged_cycles = s.engaged_cycles;
  e.aligning_mean_s = s.engagement.aligning_mean_s();
  e.aligning_max_s = s.engagement.aligning_max_s();
  e.max_reference_step_m = s.max_reference_step_m;
  e.max_aligning_force_rate_N_per_s = s.max_aligning_force_rate;
  e.latency_gate_trips = s.latency_gate_trips;
  e.new_sessions = s.new_sessions;
  e.encoder_jumps = s.reading_check->encoder_jumps();
  e.out_of_range_readings = s.reading_check->out_of_range();
  e.nonfinite_readings = s.reading_check->nonfinite();
  s.faults.Stop();
  summary.faults = s.faults.Reports();
  summary.fault_records_skipped = s.faults.skipped();
  if (s.dof_mismatches > 0) {
    spdlog::error("{} samples from the peer carried another DOF count than this process's {}: check both configs",
                  s.dof_mismatches, s.config.dof);
  }
  if (!s.finished) {
    s.finished = true;
    s.events.Stop();
    if (s.bridge) {  // DDS bridge: the summary goes out, then the bridge leaves the domain
      s.bridge->PublishSummary(summary, FormatSummaryJson(summary));
      s.bridge->Stop();
    }
  }
  return summary;
}

}  // namespace teleop::node
