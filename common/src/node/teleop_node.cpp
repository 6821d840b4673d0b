#include "teleop/node/teleop_node.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>

#include "teleop/config/render_check.hpp"
#include "teleop/dds/bridge.hpp"  // DDS bridge (docs/dds.md)
#include "teleop/device/law_command.hpp"
#include "teleop/error.hpp"
#include "teleop/link/link_config.hpp"
#include "teleop/node/event_log.hpp"
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
        events(1024) {
    const int dof = config.dof;
    device->Configure();  // opens the bus; capabilities() is final after it
    config::RequireRenderable(config, device->capabilities(), device->name());
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
  };

  void Cycle(std::uint64_t cycle, double period_s) noexcept;
  void Sense() noexcept;
  PeerState Receive(std::uint64_t cycle, std::int64_t now_ns, double t_s) noexcept;
  control::ThreeChannelLaw::Output Control(const PeerState& peer_state, double period_s) noexcept;
  /// Time-domain passivity: the law's command through the port's passivity controller (docs/stability.md).
  void Passivate(control::ThreeChannelLaw::Output& out, double period_s) noexcept;
  /// Returns whether the device reported a fault (then it was put into its safe state instead of commanded).
  bool Actuate(const control::ThreeChannelLaw::Output& out, std::uint64_t cycle, double period_s) noexcept;
  std::uint8_t Transmit(const control::ThreeChannelLaw::Output& out, const PeerState& peer_state, bool fault,
                        std::int64_t now_ns) noexcept;
  void Record(const control::ThreeChannelLaw::Output& out, const PeerState& peer_state, bool fault, std::uint8_t flags,
              std::uint64_t cycle, std::int64_t now_ns, double t_s) noexcept;
  void PushBridgeState(const runtime::TelemetryRecord& record, const control::ThreeChannelLaw::Output& out,
                       const PeerState& peer_state, bool fault) noexcept;  // DDS bridge

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

  // Preallocated cycle state.
  device::Reading reading;
  device::Command command;
  control::ThreeChannelLaw::Input input;
  control::PassivityController::Input passivity_input;
  DofVector passivity_damping;
  std::uint64_t passivity_peer_without_energy = 0;  ///< energy_exchange: samples from the peer without the block.
  DofVector zero_command;
  proto::SampleMessage incoming{};
  proto::SampleMessage peer{};
  proto::SampleMessage outgoing{};
  bool active = false;  ///< Between Device::Activate and Device::Deactivate.
  bool have_peer = false;
  bool peer_was_valid = false;
  bool peer_shutdown = false;
  bool device_faulted = false;
  std::int64_t start_ns = 0;
  std::int64_t peer_rx_ns = 0;
  std::uint32_t sequence = 0;
  std::uint8_t last_flags = 0;

  // Run statistics.
  runtime::LatencyHistogram rtt_ns;
  std::uint64_t cycles_with_peer = 0;
  std::uint64_t device_fault_cycles = 0;
  std::uint64_t saturated_cycles = 0;
  std::uint64_t nonfinite_inputs = 0;
  std::uint64_t reported_overruns = 0;
  std::uint64_t overrun_event_cycle = 0;
  std::uint64_t rate = 1000;  ///< Cycles per second, for rate-limiting events.
  double tracking_sq_sum = 0.0;
  double tracking_max = 0.0;
  double max_penetration = 0.0;
  std::uint64_t telemetry_records = 0;
  std::uint64_t dof_mismatches = 0;
  std::uint64_t link_fault_cycles = 0;
  double last_rtt_s = std::numeric_limits<double>::quiet_NaN();
  std::atomic<bool> stop_on_peer_shutdown{false};
  std::atomic<bool> stop_requested{false};
};

// The cycle, stage by stage. Each stage is noexcept, allocation-free and lock-free.

void TeleopNode::Impl::Sense() noexcept { device->Read(reading); }

TeleopNode::Impl::PeerState TeleopNode::Impl::Receive(std::uint64_t cycle, std::int64_t now_ns, double t_s) noexcept {
  if (link->Poll(incoming)) {
    if (incoming.dof != config.dof) {
      // A peer configured for another DOF count: never applied; the watchdog expires and coupling stays off.
      ++dof_mismatches;
    } else {
      peer = incoming;
      peer_rx_ns = now_ns;
      if (!have_peer) events.Push({Event::Kind::kPeerConnected, cycle, 0.0});
      have_peer = true;
      watchdog.Feed(t_s);
      const proto::RoundTripEstimate rtt = proto::EstimateRoundTrip(peer, static_cast<std::uint64_t>(now_ns));
      if (rtt.valid) {
        rtt_ns.Add(rtt.rtt_ns);
        last_rtt_s = static_cast<double>(rtt.rtt_ns) * 1e-9;
      }
      if ((peer.flags & proto::kFlagShutdown) != 0 && !peer_shutdown) {
        peer_shutdown = true;
        events.Push({Event::Kind::kPeerShutdown, cycle, 0.0});
        if (stop_on_peer_shutdown.load(std::memory_order_relaxed)) loop.Stop();
      }
      if ((peer.flags & proto::kFlagFault) != 0 && (last_flags & proto::kFlagFault) == 0) {
        events.Push({Event::Kind::kPeerFault, cycle, 0.0});
      }
      last_flags = peer.flags;
    }
  }
  PeerState state;
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

control::ThreeChannelLaw::Output TeleopNode::Impl::Control(const PeerState& peer_state, double period_s) noexcept {
  const int dof = config.dof;
  input.position_m = reading.position_m;
  input.has_velocity = device->capabilities().measures_velocity;
  input.velocity_m_per_s = reading.velocity_m_per_s;
  input.peer_valid = peer_state.usable;
  if (have_peer) {
    CopyFromWire(peer.position_m, dof, input.peer_position_m);
    CopyFromWire(peer.velocity_m_per_s, dof, input.peer_velocity_m_per_s);
    CopyFromWire(peer.force_N, dof, input.peer_force_N);
  }
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

bool TeleopNode::Impl::Actuate(const control::ThreeChannelLaw::Output& out, std::uint64_t cycle,
                               double period_s) noexcept {
  const bool fault = reading.faults != device::kFaultNone;
  if (fault) {
    device->SetSafe();
    ++device_fault_cycles;
    if (!device_faulted) events.Push({Event::Kind::kDeviceFault, cycle, static_cast<double>(reading.faults)});
  } else {
    if (device_faulted) events.Push({Event::Kind::kDeviceFaultCleared, cycle, 0.0});
    device::FillCommand(out, law.fixture(), input.position_m, command);
    device->Write(command);
  }
  device_faulted = fault;
  device->Update(period_s);
  return fault;
}

std::uint8_t TeleopNode::Impl::Transmit(const control::ThreeChannelLaw::Output& out, const PeerState& peer_state,
                                        bool fault, std::int64_t now_ns) noexcept {
  outgoing.sequence = sequence++;
  outgoing.sender_time_ns = static_cast<std::uint64_t>(now_ns);
  outgoing.echo_time_ns = have_peer ? peer.sender_time_ns : 0;
  outgoing.echo_age_ns =
      have_peer ? static_cast<std::uint32_t>(std::min<std::int64_t>(MonotonicNowNs() - peer_rx_ns, 0xFFFFFFFF)) : 0;
  std::uint8_t flags = proto::kFlagEnabled;
  if (fault || out.status == control::ThreeChannelLaw::StepStatus::kNonFiniteInput) flags |= proto::kFlagFault;
  if ((have_peer && !peer_state.fresh) || peer_state.link_faulted) flags |= proto::kFlagPeerLost;
  if (out.status == control::ThreeChannelLaw::StepStatus::kSaturated) flags |= proto::kFlagSaturated;
  if (out.fixture_penetration_m > 0.0) flags |= proto::kFlagInFixture;
  if (loop.stopping()) flags |= proto::kFlagShutdown;
  outgoing.flags = flags;
  CopyToWire(reading.position_m, outgoing.position_m);
  CopyToWire(out.velocity_m_per_s, outgoing.velocity_m_per_s);
  CopyToWire(reading.force_N, outgoing.force_N);
  // Time-domain passivity, energy_exchange: this port's energies travel with the sample (the energy block).
  outgoing.has_energy = passivity.config().mode == control::PassivityMode::kEnergyExchange;
  if (outgoing.has_energy) {
    outgoing.input_energy_J = passivity.state().input_energy_J;
    outgoing.output_energy_J = passivity.state().output_energy_J;
  }
  (void)link->Send(outgoing);  // a refused send is counted by the link
  return flags;
}

void TeleopNode::Impl::Record(const control::ThreeChannelLaw::Output& out, const PeerState& peer_state, bool fault,
                              std::uint8_t flags, std::uint64_t cycle, std::int64_t now_ns, double t_s) noexcept {
  if (out.status == control::ThreeChannelLaw::StepStatus::kSaturated) ++saturated_cycles;
  if (out.status == control::ThreeChannelLaw::StepStatus::kNonFiniteInput) {
    if (nonfinite_inputs == 0) events.Push({Event::Kind::kNonFiniteInput, cycle, 0.0});
    ++nonfinite_inputs;
  }
  if (peer_state.usable) {
    ++cycles_with_peer;
    const double e = (reading.position_m - config.law.peer_position_scale * input.peer_position_m).norm();
    tracking_sq_sum += e * e;
    tracking_max = std::max(tracking_max, e);
  }
  max_penetration = std::max(max_penetration, out.fixture_penetration_m);
  // Overruns are reported at most once a second so that a loaded machine does not flood the log.
  if (loop.stats().overruns > reported_overruns && (overrun_event_cycle == 0 || cycle >= overrun_event_cycle + rate)) {
    reported_overruns = loop.stats().overruns;
    overrun_event_cycle = cycle;
    events.Push({Event::Kind::kOverrun, cycle, static_cast<double>(reported_overruns)});
  }
  const bool to_csv = telemetry && cycle % static_cast<std::uint64_t>(config.telemetry.decimation) == 0;
  const bool to_dds = bridge && cycle % bridge_decimation == 0;  // DDS bridge
  if (to_csv || to_dds) {
    runtime::TelemetryRecord r{};
    r.cycle = cycle;
    r.time_s = t_s;
    r.dof = config.dof;
    CopyToRecord(reading.position_m, r.position_m);
    CopyToRecord(out.velocity_m_per_s, r.velocity_m_per_s);
    CopyToRecord(reading.force_N, r.force_sensor_N);
    CopyToRecord(fault ? zero_command : out.command_N, r.command_N);
    CopyToRecord(reading.rendered_force_N, r.rendered_force_N);
    CopyToRecord(out.fixture_force_N, r.fixture_force_N);
    CopyToRecord(input.peer_position_m, r.peer_position_m);
    CopyToRecord(input.peer_velocity_m_per_s, r.peer_velocity_m_per_s);
    CopyToRecord(input.peer_force_N, r.peer_force_N);
    r.fixture_penetration_m = out.fixture_penetration_m;
    r.law_status = static_cast<int>(out.status);
    r.flags = flags;
    r.rtt_s = last_rtt_s;
    r.compute_s = static_cast<double>(MonotonicNowNs() - now_ns) * 1e-9;
    for (int i = 0; i < config.dof; ++i) {  // time-domain passivity
      r.passivity_observed_J[i] = passivity.state().observed_J[static_cast<std::size_t>(i)];
      r.passivity_damping_Ns_per_m[i] = i < passivity_damping.size() ? passivity_damping[i] : 0.0;
    }
    if (to_csv && telemetry->Push(r)) ++telemetry_records;
    if (to_dds) PushBridgeState(r, out, peer_state, fault);  // DDS bridge
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

void TeleopNode::Impl::Cycle(std::uint64_t cycle, double period_s) noexcept {
  const std::int64_t now_ns = MonotonicNowNs();
  if (cycle == 0) start_ns = now_ns;
  const double t_s = static_cast<double>(now_ns - start_ns) * 1e-9;
  Sense();                                                              // 1. device → reading
  const PeerState peer_state = Receive(cycle, now_ns, t_s);             // 2. drain the link, keep the newest sample
  const auto out = Control(peer_state, period_s);                       // 3. the law
  const bool fault = Actuate(out, cycle, period_s);                     // 4. command (or safe state on a fault), Update
  const std::uint8_t flags = Transmit(out, peer_state, fault, now_ns);  // 5. this cycle's sample, with the echo
  Record(out, peer_state, fault, flags, cycle, now_ns, t_s);            // 6. statistics, events, telemetry
}

TeleopNode::TeleopNode(const config::ProcessConfig& config, std::unique_ptr<device::Device> device,
                       std::unique_ptr<transport::Link> link)
    : impl_(std::make_unique<Impl>(config, std::move(device), std::move(link))) {}

TeleopNode::~TeleopNode() = default;

void TeleopNode::Step(std::uint64_t cycle, double period_s) noexcept { impl_->Cycle(cycle, period_s); }

void TeleopNode::Stop() noexcept {
  impl_->stop_requested.store(true, std::memory_order_relaxed);
  impl_->loop.Stop();
}

RunSummary TeleopNode::Run() {
  Impl& s = *impl_;
  s.stop_on_peer_shutdown.store(true);
  spdlog::info("teleop-{}: {} DOF at {:.0f} Hz, device '{}', link {}", ToString(s.config.role), s.config.dof,
               s.config.loop.rate_hz, s.device->name(), s.link->Describe());
  const auto wall_start = std::chrono::steady_clock::now();
  s.loop.Run([&s](std::uint64_t cycle, double period_s) { s.Cycle(cycle, period_s); });
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  // Tell the peer we are going, so it stops coupling without a watchdog fault; then hold the safe state.
  s.outgoing.flags = proto::kFlagShutdown;
  s.outgoing.sequence = s.sequence++;
  (void)s.link->Send(s.outgoing);
  s.device->Deactivate();
  s.active = false;

  RunSummary summary;
  summary.role = s.config.role;
  summary.rate_hz = s.config.loop.rate_hz;
  const auto& st = s.loop.stats();
  summary.cycles = st.cycles;
  summary.duration_s = wall_s;
  summary.achieved_rate_hz = wall_s > 0 ? static_cast<double>(st.cycles) / wall_s : 0.0;
  summary.overruns = st.overruns;
  summary.period_us = FromHistogram(st.period_ns, 1e3);
  summary.jitter_us = FromHistogram(st.jitter_ns, 1e3);
  summary.compute_us = FromHistogram(st.compute_ns, 1e3);
  summary.link = s.link->counters();
  summary.rtt_ms = FromHistogram(s.rtt_ns, 1e6);
  summary.cycles_with_peer = s.cycles_with_peer;
  summary.watchdog_trips = s.watchdog.trips();
  summary.device_fault_cycles = s.device_fault_cycles;
  summary.nonfinite_inputs = s.nonfinite_inputs;
  summary.saturated_cycles = s.saturated_cycles;
  summary.tracking_error_rms_m =
      s.cycles_with_peer > 0 ? std::sqrt(s.tracking_sq_sum / static_cast<double>(s.cycles_with_peer)) : 0.0;
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
  if (s.dof_mismatches > 0) {
    spdlog::error("{} samples from the peer carried another DOF count than this process's {}: check both configs",
                  s.dof_mismatches, s.config.dof);
  }
  s.events.Stop();
  if (s.bridge) {  // DDS bridge: the summary goes out, then the bridge leaves the domain
    s.bridge->PublishSummary(summary, FormatSummaryJson(summary));
    s.bridge->Stop();
  }
  return summary;
}

}  // namespace teleop::node
