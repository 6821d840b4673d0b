#include "teleop/node/teleop_node.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "teleop/config/render_check.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/impaired_link.hpp"
#include "teleop/version.hpp"
#include "teleop_node_impl.hpp"

namespace teleop::node {

namespace {

using runtime::MonotonicNowNs;

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

/// The config sections the coupling uses, and what it needs of the device.
Coupling::Config CouplingConfigOf(const config::ProcessConfig& config, const device::Capabilities& caps) {
  Coupling::Config c;
  c.role = config.role;
  c.dof = config.dof;
  c.law = config.law;
  c.engagement = config.engagement;
  c.safety = config.safety;
  c.passivity = config.passivity;
  c.measures_velocity = caps.measures_velocity;
  c.can_push = caps.can_push();
  return c;
}

device::Reading ZeroReading(int dof, int joints) {
  device::Reading r;
  r.position_m = r.velocity_m_per_s = r.force_N = r.rendered_force_N = ZeroDof(dof);
  r.joint_position_rad = r.joint_torque_Nm = DofVector::Zero(joints);
  return r;
}

}  // namespace

void TeleopNode::Impl::Configure() {
  if (phase != Phase::kUnconfigured) throw Error("teleop node: Configure() twice");
  const int dof = config.dof;
  device->Configure();  // opens the bus; capabilities() is final after it
  const device::Capabilities& caps = device->capabilities();
  config::RequireRenderable(config, caps, device->name());
  RequireReaction(config, caps, device->name());
  reading_check = std::make_unique<ReadingCheck>(config.safety, caps, dof);
  if (caps.joints < 0 || caps.joints > kMaxDof) {
    throw Error("device '" + device->name() + "' reports " + std::to_string(caps.joints) + " joints, outside 0.." +
                std::to_string(kMaxDof));
  }
  reading = ZeroReading(dof, caps.joints);
  PeerTracker::Config pc;
  pc.dof = dof;
  pc.timeout_s = config.link.timeout_ms * 1e-3;
  pc.max_rtt_s = config.engagement.max_rtt_ms * 1e-3;
  peer = std::make_unique<PeerTracker>(pc, *link, events, clock);
  coupling = std::make_unique<Coupling>(CouplingConfigOf(config, caps), events);
  fixture_on_N_per_m = config.law.fixture.stiffness_N_per_m;
  check_base = config;
  // A run-time gain change changes this side only: the peer keeps the gains the start-up check assumed for it.
  config::StabilityConfig::Peer& assumed = check_base.stability.peer;
  if (!assumed.kp_N_per_m) assumed.kp_N_per_m = config.law.kp_N_per_m;
  if (!assumed.kd_Ns_per_m) assumed.kd_Ns_per_m = config.law.kd_Ns_per_m;
  if (!assumed.kv_Ns_per_m) assumed.kv_Ns_per_m = config.law.kv_Ns_per_m;
  if (!assumed.kf) assumed.kf = config.law.kf;
  transmitter = std::make_unique<Transmitter>(config.role, dof, *link, clock);
  Recorder::Config rc;
  rc.dof = dof;
  rc.joints = caps.joints;
  rc.peer_position_scale = config.law.peer_position_scale;
  rc.rate = static_cast<std::uint64_t>(config.loop.rate_hz);
  recorder = std::make_unique<Recorder>(rc, sinks, events);
  sinks.Add(MakeFaultRingSink(config, caps.joints));
  sinks.Add(MakeTelemetryCsvSink(config, caps.joints));
  sinks.Add(MakeDdsSink(config));
  for (auto& sink : added_sinks) sinks.Add(std::move(sink));
  events.SetObserver(&sinks);
  phase = Phase::kConfigured;
}

void TeleopNode::Impl::ActivateDevice() {
  if (phase != Phase::kConfigured) throw Error("teleop node: Activate() needs a configured, inactive node");
  device->Activate();  // last: a failure before it leaves the device configured but never rendering
  phase = Phase::kActive;
}

void TeleopNode::Impl::DeactivateDevice() noexcept {
  if (phase != Phase::kActive) return;
  device->Deactivate();
  phase = Phase::kInactive;
}

// The cycle: each stage takes the values of the stages before it and returns its own. Noexcept, allocation-free.
void TeleopNode::Impl::Cycle(std::uint64_t cycle, double period_s, std::int64_t now_ns) noexcept {
  if (phase != Phase::kActive) return;
  const std::int64_t cycle_start_mono_ns = MonotonicNowNs();
  if (cycle == 0 || stepped_cycles == 0) start_ns = now_ns;
  ++stepped_cycles;
  const double t_s = static_cast<double>(now_ns - start_ns) * 1e-9;
  const Sensed sensed = Sense(period_s);                                         // 1. device → reading
  const PeerView view = peer->Step(cycle, now_ns, t_s, loop.cycle_triggered());  // 2. link → the peer
  if (view.shutdown_started && stop_on_peer_shutdown.load(std::memory_order_relaxed)) loop.Stop();
  const std::int64_t law_start_ns = clock.Now();
  Changes changes = commands.Drain(command_clutch.load(std::memory_order_relaxed), cycle, events);  // commands
  BoundChangeRamps(changes, view);
  const Applied applied = coupling->Step(sensed, view, changes, cycle, t_s, period_s);   // 3. the command applied
  Actuate(applied, period_s);                                                            // 4. → device
  const std::uint8_t flags = transmitter->Send(sensed, view, applied, loop.stopping());  // 5. → peer
  peer_sender_age_ns.store(view.usable ? peer->data_age().SenderAgeNs(law_start_ns) : -1, std::memory_order_relaxed);
  const std::int64_t age_ns = peer->UsedAt(law_start_ns, view.usable);
  recorder->Step(sensed, view, applied, Facts(cycle, t_s, flags, age_ns, cycle_start_mono_ns, view.usable));  // 6.
}

void TeleopNode::Impl::BoundChangeRamps(Changes& changes, const PeerView& view) noexcept {
  const int dof = config.dof;
  const double max_rate = config.engagement.max_force_rate_N_per_s;
  if (changes.has_stiffness && reading.position_m.size() == dof) {
    const DofVector& offset = coupling->law_input_state().index_offset_m;
    ramp_position_m = reading.position_m;
    if (offset.size() == dof) ramp_position_m += offset;
    changes.stiffness.ramp_s = std::max(
        changes.stiffness.ramp_s,
        StiffnessRampFloor_s(coupling->law().fixture(), ramp_position_m, changes.stiffness.target_N_per_m, max_rate));
  }
  if (changes.has_gains) {
    const DofVector targets[4] = {changes.gains.kp_N_per_m, changes.gains.kd_Ns_per_m, changes.gains.kv_Ns_per_m,
                                  changes.gains.kf};
    changes.gains.ramp_s =
        std::max(changes.gains.ramp_s, GainRampFloor_s(coupling->law().config(), targets, Signals(view), max_rate));
  }
}

const GainSignals& TeleopNode::Impl::Signals(const PeerView& view) noexcept {
  const int dof = config.dof;
  const control::ThreeChannelLaw::Config& law = coupling->law().config();
  GainSignals& s = signals;
  s.velocity_m_per_s = coupling->state().last_velocity;  // the law's, measured or estimated
  if (s.velocity_m_per_s.size() != dof) s.velocity_m_per_s = ZeroDof(dof);
  s.position_error_m.setZero(dof);
  s.velocity_error_m_per_s.setZero(dof);
  s.peer_force_N.setZero(dof);
  const DofVector& offset = coupling->law_input_state().index_offset_m;
  if (!view.have_peer || reading.position_m.size() != dof) return s;
  for (int i = 0; i < dof; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double shift = offset.size() == dof ? offset[i] : 0.0;
    s.position_error_m[i] = reading.position_m[i] + shift - law.peer_position_scale * view.sample->position_m[k];
    s.velocity_error_m_per_s[i] = s.velocity_m_per_s[i] - law.peer_position_scale * view.sample->velocity_m_per_s[k];
    s.peer_force_N[i] = law.peer_force_scale * view.sample->force_N[k];
  }
  return s;
}

Sensed TeleopNode::Impl::Sense(double period_s) noexcept {
  if (exchange != nullptr) exchange->Exchange();  // the cycle's one bus exchange (TPDOs in, the SYNC out)
  device->Read(reading);
  return Sensed{&reading, reading.faults | reading_check->Check(reading, period_s)};
}

void TeleopNode::Impl::Actuate(const Applied& applied, double period_s) noexcept {
  if (applied.safe) {
    device->SetSafe();
  } else {
    device->Write(applied.device_command);
  }
  device->Update(period_s);
}

CycleFacts TeleopNode::Impl::Facts(std::uint64_t cycle, double t_s, std::uint8_t flags, std::int64_t data_age_ns,
                                   std::int64_t cycle_start_mono_ns, bool usable) const noexcept {
  CycleFacts f;
  f.cycle = cycle;
  f.t_s = t_s;
  f.flags = flags;
  f.data_age_ns = data_age_ns;
  f.fixture_limit_N_per_m = fixture_limit_N_per_m.load(std::memory_order_relaxed);
  f.cycle_start_mono_ns = cycle_start_mono_ns;
  f.stopping = loop.stopping();
  f.coupled_trigger_timeout = usable && loop.triggered_mode() && !loop.cycle_triggered();
  f.overruns = loop.stats().overruns;
  f.watchdog_trips = peer->watchdog().trips();
  f.link = &link->counters();
  return f;
}

TeleopNode::TeleopNode(const config::ProcessConfig& config, std::unique_ptr<device::Device> device,
                       std::unique_ptr<transport::Link> link)
    : TeleopNode(config, std::move(device), std::move(link), Unconfigured{}) {
  impl_->Configure();
  impl_->ActivateDevice();
}

TeleopNode::TeleopNode(const config::ProcessConfig& config, std::unique_ptr<device::Device> device,
                       std::unique_ptr<transport::Link> link, Unconfigured)
    : impl_(std::make_unique<Impl>(config, std::move(device), std::move(link))) {}

TeleopNode::~TeleopNode() = default;

void TeleopNode::AddSink(std::unique_ptr<CycleSink> sink) {
  if (impl_->phase != Impl::Phase::kUnconfigured) throw Error("teleop node: AddSink() after Configure()");
  impl_->added_sinks.push_back(std::move(sink));
}

void TeleopNode::Configure() { impl_->Configure(); }

void TeleopNode::Activate() {
  if (impl_->phase != Impl::Phase::kConfigured) throw Error("teleop node: Activate() needs Configure() first");
  impl_->loop.ApplyRealtimeSettings();  // throws before the device is activated
  impl_->ActivateDevice();
}

void TeleopNode::Deactivate() noexcept { impl_->DeactivateDevice(); }

void TeleopNode::Step(std::uint64_t cycle, double period_s) noexcept {
  impl_->clock.stepped = false;
  impl_->Cycle(cycle, period_s, MonotonicNowNs());
}

void TeleopNode::Step(std::uint64_t cycle, double period_s, std::int64_t now_ns) noexcept {
  impl_->clock.stepped = true;
  impl_->clock.stepped_now_ns = now_ns;
  impl_->Cycle(cycle, period_s, now_ns);
}

EngagementState TeleopNode::engagement() const noexcept {
  return impl_->coupling ? impl_->coupling->engagement().state() : EngagementState::kDisengaged;
}

void TeleopNode::SetClutch(bool pressed) noexcept { impl_->command_clutch.store(pressed, std::memory_order_relaxed); }

bool TeleopNode::clutched() const noexcept { return impl_->coupling && impl_->coupling->clutch_state().sources != 0; }

double TeleopNode::index_offset_m(int axis) const noexcept {
  if (!impl_->coupling) return 0.0;
  const DofVector& o = impl_->coupling->law_input_state().index_offset_m;
  return axis >= 0 && axis < o.size() ? o[axis] : 0.0;
}

double TeleopNode::max_clutch_force_rate_N_per_s() const noexcept {
  return impl_->coupling ? impl_->coupling->shaper_state().max_clutch_force_rate : 0.0;
}

int TeleopNode::dof() const noexcept { return impl_->config.dof; }

control::FixturePlane TeleopNode::fixture_plane(int index) const noexcept {
  if (!impl_->coupling) return {};
  const control::ForbiddenRegionFixture::Config& f = impl_->coupling->law().fixture().config();
  return index >= 0 && index < f.plane_count ? f.planes[static_cast<std::size_t>(index)] : control::FixturePlane{};
}

double TeleopNode::max_plane_offset_step_m() const noexcept {
  return impl_->coupling ? impl_->coupling->setpoints_state().max_plane_offset_step_m : 0.0;
}

double TeleopNode::max_plane_normal_step_rad() const noexcept {
  return impl_->coupling ? impl_->coupling->setpoints_state().max_plane_normal_step_rad : 0.0;
}

double TeleopNode::gain(GainName name, int axis) const noexcept {
  if (!impl_->coupling) return 0.0;
  const control::ThreeChannelLaw::Config& c = impl_->coupling->law().config();
  const DofVector& g = name == GainName::kKp   ? c.kp_N_per_m
                       : name == GainName::kKd ? c.kd_Ns_per_m
                       : name == GainName::kKv ? c.kv_Ns_per_m
                                               : c.kf;
  return axis >= 0 && axis < g.size() ? g[axis] : 0.0;
}

double TeleopNode::peer_data_age_s() const noexcept {
  const std::int64_t ns = impl_->peer_sender_age_ns.load(std::memory_order_relaxed);
  return ns >= 0 ? static_cast<double>(ns) * 1e-9 : -1.0;
}

double TeleopNode::fixture_stiffness_N_per_m() const noexcept {
  return impl_->coupling ? impl_->coupling->law().fixture().config().stiffness_N_per_m : 0.0;
}

void TeleopNode::Stop() noexcept {
  impl_->stop_requested.store(true, std::memory_order_relaxed);
  impl_->loop.Stop();
}

RunSummary TeleopNode::Run() {
  Impl& s = *impl_;
  if (s.phase != Impl::Phase::kActive) throw Error("teleop node: Run() needs an active node (Activate())");
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
  s.transmitter->SendShutdown();  // the peer stops coupling without a watchdog fault; then the safe state
  return s.Summarize(wall_s);
}

RunSummary TeleopNode::Finish() { return impl_->Summarize(0.0); }

void TeleopNode::SetSessionRecord(std::string config_path, std::string config_yaml, std::string startup_analysis) {
  impl_->session_config_path = std::move(config_path);
  impl_->session_config_yaml = std::move(config_yaml);
  impl_->session_startup_analysis = std::move(startup_analysis);
}

void TeleopNode::Impl::SummarizeLoop(RunSummary& summary, double wall_s) const {
  const auto& st = loop.stats();
  summary.role = config.role;
  summary.software_version = SoftwareVersion();  // the version in every summary (issue 30)
  summary.protocol_version = config.link.security.mode == transport::LinkSecurityMode::kPsk
                                 ? proto::kSecureProtocolVersion
                                 : proto::kProtocolVersion;
  summary.rate_hz = config.loop.rate_hz;
  summary.cycles = std::max(st.cycles, stepped_cycles);
  summary.duration_s = wall_s;
  summary.achieved_rate_hz = wall_s > 0 ? static_cast<double>(st.cycles) / wall_s : 0.0;
  summary.overruns = st.overruns;
  summary.period_us = FromHistogram(st.period_ns, 1e3);
  summary.jitter_us = FromHistogram(st.jitter_ns, 1e3);
  summary.compute_us = FromHistogram(st.compute_ns, 1e3);
  summary.sync = runtime::ToString(config.loop.sync);
  summary.triggered_cycles = st.triggered_cycles;
  summary.trigger_timeouts = st.trigger_timeouts;
  summary.realtime_settings_applied = st.realtime_settings_applied;
  summary.cpu_dma_latency_held = st.cpu_dma_latency_held;
  summary.stop_reason = stop_requested.load()                   ? "signal"
                        : (peer && peer->state().peer_shutdown) ? "peer shutdown"
                                                                : "duration";
}

void TeleopNode::Impl::SummarizeLink(RunSummary& summary) const {
  summary.link = link->counters();
  summary.link_detail = link->Summary();
  if (const auto* emulation = transport::EmulationCountersOf(*link)) summary.link_emulation = *emulation;
  summary.link_security = transport::ToString(config.link.security.mode);
  summary.link_transport = config.link.transport;  // the round-trip line per transport (issue 30)
  if (!peer) return;
  const PeerTracker::State& p = peer->state();
  summary.rtt_ms = FromHistogram(peer->rtt_ns(), 1e6);
  summary.data_age_us = FromHistogram(peer->data_age().receive_age_ns(), 1e3);
  summary.data_age_sender_us = FromHistogram(peer->data_age().sender_age_ns(), 1e3);
  summary.data_age_cycles = peer->data_age().age_cycles();
  summary.watchdog_trips = peer->watchdog().trips();
  summary.dof_mismatches = p.dof_mismatches;
  summary.link_fault_cycles = p.link_fault_cycles;
  summary.engagement.latency_gate_trips = p.latency_gate_trips;
  // The clock of this side's telemetry and the peer's offset, for the session record (issue 30).
  summary.clock_start_monotonic_ns = start_ns;
  if (p.have_best_offset) {
    summary.peer_clock_offset_ns = p.best_offset_ns;
    summary.peer_clock_offset_uncertainty_ns = p.best_rtt_ns / 2;
  }
  summary.engagement.new_sessions = p.new_sessions;
}

void TeleopNode::Impl::SummarizeCoupling(RunSummary& summary) const {
  if (!coupling) return;
  const Recorder::State& r = recorder->state();
  summary.trigger_timeouts_coupled = r.coupled_trigger_timeouts;
  summary.cycles_with_peer = r.cycles_with_peer;
  summary.device_fault_cycles = r.device_fault_cycles;
  summary.nonfinite_inputs = r.nonfinite_inputs;
  summary.saturated_cycles = r.saturated_cycles;
  summary.tracking_error_rms_m =
      r.engaged_cycles > 0 ? std::sqrt(r.tracking_sq_sum / static_cast<double>(r.engaged_cycles)) : 0.0;
  summary.tracking_error_max_m = r.tracking_max;
  summary.fixture_max_penetration_m = r.max_penetration;
  summary.device_warnings.changes = r.device_warning_changes;
  summary.device_warnings.cycles = r.device_warning_cycles;
  summary.device_warnings.last = r.device_warnings;
  summary.device_warnings.seen = r.device_warnings_seen;
  const control::PassivityController& pc = coupling->passivity();
  summary.passivity_mode = control::ToString(pc.config().mode);
  summary.passivity_cycles = pc.state().acting_steps;
  summary.passivity_dissipated_J = pc.total_dissipated_J();
  summary.passivity_min_observed_J = pc.state().min_observed_J;
  summary.passivity_peer_without_energy = coupling->passivity_state().peer_without_energy;
  const EngagementMachine& m = coupling->engagement();
  EngagementSummary& e = summary.engagement;
  e.reaction = ToString(config.safety.reaction);
  e.final_state = ToString(m.state());
  e.times_engaged = m.engagements();
  e.couplings_lost = m.couplings_lost();
  e.engaged_cycles = r.engaged_cycles;
  e.aligning_mean_s = m.aligning_mean_s();
  e.aligning_max_s = m.aligning_max_s();
  e.max_reference_step_m = coupling->law_input_state().max_reference_step_m;
  e.max_aligning_force_rate_N_per_s = coupling->shaper_state().max_aligning_force_rate;
  e.encoder_jumps = reading_check->encoder_jumps();
  e.out_of_range_readings = reading_check->out_of_range();
  e.nonfinite_readings = reading_check->nonfinite();
}

RunSummary TeleopNode::Impl::Summarize(double wall_s) {
  DeactivateDevice();
  RunSummary summary;
  SummarizeLoop(summary, wall_s);
  SummarizeLink(summary);
  SummarizeCoupling(summary);
  summary.telemetry_csv = config.telemetry.csv_path;
  summary.config_path = session_config_path;
  summary.config_yaml = session_config_yaml;
  summary.startup_analysis = session_startup_analysis;
  sinks.Finish(summary);  // the CSV's and the fault ring's counts
  if (summary.passivity_peer_without_energy > 0) {
    spdlog::error(
        "passivity energy_exchange: {} samples from the peer carried no energy block, so this side could "
        "give out nothing: set passivity.mode: energy_exchange on both processes",
        summary.passivity_peer_without_energy);
  }
  if (summary.dof_mismatches > 0) {
    spdlog::error("{} samples from the peer carried another DOF count than this process's {}: check both configs",
                  summary.dof_mismatches, config.dof);
  }
  if (!published) {
    published = true;
    events.Stop();
    sinks.Publish(summary);  // after the last event: the DDS bridge sends the summary and leaves the domain
  }
  return summary;
}

}  // namespace teleop::node
