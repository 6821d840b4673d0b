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
#include "teleop/runtime/data_age.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "teleop/runtime/telemetry.hpp"
#include "teleop/runtime/watchdog.hpp"

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

}  // namespace

struct TeleopNode::Impl {
  Impl(const config::ProcessConfig& cfg, std::unique_ptr<device::Device> dev, std::unique_ptr<transport::Link> lnk)
      : config(cfg),
        device(std::move(dev)),
        link(std::move(lnk)),
        law(cfg.law),
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
      // The medium's receive time (the kernel's timestamp on UDP) makes the round trip and the data age the
      // network's and the sample's, not the phase between two cycles; the cycle start where the link has none.
      const std::int64_t received_ns = link->newest_receive_time_ns();
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
      }
      const std::int64_t sent_local_ns =
          have_offset ? static_cast<std::int64_t>(peer.sender_time_ns) - peer_clock_offset_ns : 0;
      data_age.OnNewSample(peer_rx_ns, sent_local_ns, loop.cycle_triggered());
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
  law_start_ns = MonotonicNowNs();
  return law.Step(input, period_s);
}

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
  outgoing.echo_time_ns = have_peer ? peer.sender_time_ns : 0;
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
  // Send time and echo age taken right before the send call (docs/protocol.md, "Round-trip time").
  const std::int64_t send_ns = MonotonicNowNs();
  outgoing.sender_time_ns = static_cast<std::uint64_t>(send_ns);
  outgoing.echo_age_ns =
      have_peer ? static_cast<std::uint32_t>(std::clamp<std::int64_t>(send_ns - peer_rx_ns, 0, 0xFFFFFFFF)) : 0;
  (void)now_ns;
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
  const std::int64_t age_ns = peer_state.usable ? data_age.ReceiveAgeNs(law_start_ns) : -1;
  data_age.OnCycle(law_start_ns, peer_state.usable);
  if (peer_state.usable && loop.triggered_mode() && !loop.cycle_triggered()) ++coupled_trigger_timeouts;
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
    r.data_age_s = age_ns >= 0 ? static_cast<double>(age_ns) * 1e-9 : std::numeric_limits<double>::quiet_NaN();
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
