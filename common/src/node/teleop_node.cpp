#include "teleop/node/teleop_node.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>

#include "change_ramp.hpp"
#include "coupling.hpp"
#include "peer_tracker.hpp"
#include "recorder.hpp"
#include "sinks.hpp"
#include "teleop/config/render_check.hpp"
#include "teleop/config/stability_check.hpp"
#include "teleop/device/law_command.hpp"
#include "teleop/error.hpp"
#include "teleop/node/event_log.hpp"
#include "teleop/node/reading_check.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "teleop/runtime/spsc_ring.hpp"
#include "teleop/transport/impaired_link.hpp"
#include "teleop/version.hpp"
#include "transmitter.hpp"

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

std::string Num(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

device::Reading ZeroReading(int dof) {
  device::Reading r;
  r.position_m = r.velocity_m_per_s = r.force_N = r.rendered_force_N = ZeroDof(dof);
  return r;
}

}  // namespace

struct TeleopNode::Impl {
  enum class Phase : std::uint8_t { kUnconfigured, kConfigured, kActive, kInactive };

  Impl(const config::ProcessConfig& cfg, std::unique_ptr<device::Device> dev, std::unique_ptr<transport::Link> lnk)
      : config(cfg), device(std::move(dev)), link(std::move(lnk)), loop(cfg.loop), events(1024) {}
  ~Impl() { DeactivateDevice(); }

  void Configure();
  void ActivateDevice();
  void DeactivateDevice() noexcept;
  void Cycle(std::uint64_t cycle, double period_s, std::int64_t now_ns) noexcept;
  Sensed Sense(double period_s) noexcept;
  void Actuate(const Applied& applied, double period_s) noexcept;
  CycleFacts Facts(std::uint64_t cycle, double t_s, std::uint8_t flags, std::int64_t data_age_ns,
                   std::int64_t cycle_start_mono_ns, bool usable) const noexcept;
  RunSummary Summarize(double wall_s);
  void SummarizeLoop(RunSummary& summary, double wall_s) const;
  void SummarizeLink(RunSummary& summary) const;
  void SummarizeCoupling(RunSummary& summary) const;

  config::ProcessConfig config;
  std::unique_ptr<device::Device> device;
  std::unique_ptr<transport::Link> link;
  runtime::PeriodicLoop loop;
  SinkSet sinks;                                        ///< Declared before `events`: outlives its observer role.
  std::vector<std::unique_ptr<CycleSink>> added_sinks;  ///< TeleopNode::AddSink, after the node's own.
  EventLog events;
  NodeClock clock;
  Phase phase = Phase::kUnconfigured;

  // The stages (built by Configure: they need the device's capabilities).
  std::unique_ptr<ReadingCheck> reading_check;
  std::unique_ptr<PeerTracker> peer;
  std::unique_ptr<Coupling> coupling;
  std::unique_ptr<Transmitter> transmitter;
  std::unique_ptr<Recorder> recorder;

  // Preallocated values of the cycle.
  device::Reading reading;
  device::Command command;
  std::uint64_t stepped_cycles = 0;
  std::int64_t start_ns = 0;
  std::atomic<bool> stop_on_peer_shutdown{false};
  std::atomic<bool> stop_requested{false};
  std::atomic<bool> command_clutch{false};  ///< TeleopNode::SetClutch (any thread) → the cycle.

  /// A command's outcome (and, when accepted, its change) from the command side to the cycle, which applies the
  /// change and logs the event (the event ring has one producer, the cycle). Producers are serialised by
  /// command_mutex: the ring is single-producer single-consumer, wait-free on both ends.
  struct PendingCommand {
    enum class Change : std::uint8_t { kNone, kStiffness, kGains, kPlane };
    Event::Kind kind = Event::Kind::kCommandRefused;
    double value = 0.0;
    std::uint16_t detail = 0;
    Change change = Change::kNone;
    double ramp_s = 0.0;
    double stiffness_N_per_m = 0.0;
    std::array<std::array<double, kMaxDof>, 4> gains{};  ///< kp, kd, kv, kf (the targets).
    std::array<double, kMaxDof> normal{};
    double offset_m = 0.0;
    double offset_rate_m_per_s = 0.0;
    double normal_rate_rad_per_s = 0.0;
  };
  static constexpr std::size_t kCommandRing = 64;
  static constexpr int kCommandsPerCycle = 8;  ///< Drained per cycle at most (bounds the cycle's work).
  runtime::SpscRing<PendingCommand> command_ring{kCommandRing};
  std::atomic<std::uint64_t> command_events_dropped{0};
  std::mutex command_mutex;          ///< Serialises the producers and guards what follows.
  config::ProcessConfig check_base;  ///< What the next check starts from: accepted changes applied.
  double fixture_on_N_per_m = 0.0;   ///< What `fixture on` restores.
  PendingCommand pending;            ///< The cycle's copy of a popped command.
  DofVector pending_gains[4];        ///< ... its gains, and its normal, as DofVectors (preallocated).
  DofVector pending_normal;

  /// With command_mutex held. False (counted) when the ring is full.
  bool Post(const PendingCommand& p) noexcept {
    if (command_ring.TryPush(p)) return true;
    command_events_dropped.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  void DrainCommands(std::uint64_t cycle, const PeerView& view) noexcept;
  /// What the law's gains multiply now (change_ramp.hpp), from this cycle's reading and peer (preallocated).
  const GainSignals& Signals(const PeerView& view) noexcept;
  GainSignals signals;
  bool published = false;
};

void TeleopNode::Impl::Configure() {
  if (phase != Phase::kUnconfigured) throw Error("teleop node: Configure() twice");
  const int dof = config.dof;
  device->Configure();  // opens the bus; capabilities() is final after it
  const device::Capabilities& caps = device->capabilities();
  config::RequireRenderable(config, caps, device->name());
  RequireReaction(config, caps, device->name());
  reading_check = std::make_unique<ReadingCheck>(config.safety, caps, dof);
  reading = ZeroReading(dof);
  command = device::Command::Force(ZeroDof(dof));
  PeerTracker::Config pc;
  pc.dof = dof;
  pc.timeout_s = config.link.timeout_ms * 1e-3;
  pc.max_rtt_s = config.engagement.max_rtt_ms * 1e-3;
  peer = std::make_unique<PeerTracker>(pc, *link, events, clock);
  coupling = std::make_unique<Coupling>(Coupling::Config{config, caps.measures_velocity, caps.can_push()}, events);
  fixture_on_N_per_m = config.law.fixture.stiffness_N_per_m;
  check_base = config;
  // A run-time gain change changes this side only: the peer keeps the gains the start-up check assumed for it.
  config::StabilityConfig::Peer& assumed = check_base.stability.peer;
  if (!assumed.kp_N_per_m) assumed.kp_N_per_m = config.law.kp_N_per_m;
  if (!assumed.kd_Ns_per_m) assumed.kd_Ns_per_m = config.law.kd_Ns_per_m;
  if (!assumed.kv_Ns_per_m) assumed.kv_Ns_per_m = config.law.kv_Ns_per_m;
  if (!assumed.kf) assumed.kf = config.law.kf;
  for (DofVector& g : pending_gains) g = ZeroDof(dof);
  pending_normal = ZeroDof(dof);
  transmitter = std::make_unique<Transmitter>(config.role, dof, *link, clock);
  Recorder::Config rc;
  rc.dof = dof;
  rc.peer_position_scale = config.law.peer_position_scale;
  rc.rate = static_cast<std::uint64_t>(config.loop.rate_hz);
  recorder = std::make_unique<Recorder>(rc, sinks, events);
  sinks.Add(MakeFaultRingSink(config));
  sinks.Add(MakeTelemetryCsvSink(config));
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
  coupling->SetCommandClutch(command_clutch.load(std::memory_order_relaxed));
  DrainCommands(cycle, view);
  const Applied& applied = coupling->Step(sensed, view, cycle, t_s, period_s);           // 3. the command applied
  Actuate(applied, period_s);                                                            // 4. → device
  const std::uint8_t flags = transmitter->Send(sensed, view, applied, loop.stopping());  // 5. → peer
  const std::int64_t age_ns = peer->UsedAt(law_start_ns, view.usable);
  recorder->Step(sensed, view, applied, Facts(cycle, t_s, flags, age_ns, cycle_start_mono_ns, view.usable));  // 6.
}

// A stiffness or gain change takes at least the ramp that keeps its own force change within
// engagement.max_force_rate_N_per_s at this cycle's position (change_ramp.hpp): a ramp of 0 is not a force step.
void TeleopNode::Impl::DrainCommands(std::uint64_t cycle, const PeerView& view) noexcept {
  using Change = PendingCommand::Change;
  const int dof = config.dof;
  const double max_rate = config.engagement.max_force_rate_N_per_s;
  for (int n = 0; n < kCommandsPerCycle && command_ring.TryPop(pending); ++n) {
    switch (pending.change) {
      case Change::kNone:
        break;
      case Change::kStiffness: {
        const DofVector& x = reading.position_m;
        const double floor_s =
            x.size() == dof ? StiffnessRampFloor_s(coupling->law().fixture(), x + coupling->state().index_offset_m,
                                                   pending.stiffness_N_per_m, max_rate)
                            : 0.0;
        coupling->RampFixtureStiffness(pending.stiffness_N_per_m, std::max(pending.ramp_s, floor_s));
        break;
      }
      case Change::kGains:
        for (int g = 0; g < 4; ++g) {
          for (int i = 0; i < dof; ++i) pending_gains[g][i] = pending.gains[static_cast<std::size_t>(g)][i];
        }
        coupling->RampGains(pending_gains[0], pending_gains[1], pending_gains[2], pending_gains[3],
                            std::max(pending.ramp_s, GainRampFloor_s(coupling->law().config(), pending_gains,
                                                                     Signals(view), max_rate)));
        break;
      case Change::kPlane:
        for (int i = 0; i < dof; ++i) pending_normal[i] = pending.normal[static_cast<std::size_t>(i)];
        coupling->MovePlane(0, pending_normal, pending.offset_m, pending.offset_rate_m_per_s,
                            pending.normal_rate_rad_per_s);
        break;
    }
    events.Push({pending.kind, cycle, pending.value, pending.detail});
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
  if (!view.have_peer || reading.position_m.size() != dof) return s;
  for (int i = 0; i < dof; ++i) {
    const auto k = static_cast<std::size_t>(i);
    s.position_error_m[i] = reading.position_m[i] + coupling->state().index_offset_m[i] -
                            law.peer_position_scale * view.sample->position_m[k];
    s.velocity_error_m_per_s[i] = s.velocity_m_per_s[i] - law.peer_position_scale * view.sample->velocity_m_per_s[k];
    s.peer_force_N[i] = law.peer_force_scale * view.sample->force_N[k];
  }
  return s;
}

Sensed TeleopNode::Impl::Sense(double period_s) noexcept {
  device->Read(reading);
  return Sensed{&reading, reading.faults | reading_check->Check(reading, period_s)};
}

void TeleopNode::Impl::Actuate(const Applied& applied, double period_s) noexcept {
  if (applied.safe) {
    device->SetSafe();
  } else {
    device::FillCommand(applied.command, coupling->law().fixture(), applied.law_input->position_m, command);
    device->Write(command);
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

bool TeleopNode::clutched() const noexcept { return impl_->coupling && impl_->coupling->state().clutch_sources != 0; }

double TeleopNode::index_offset_m(int axis) const noexcept {
  if (!impl_->coupling) return 0.0;
  const DofVector& o = impl_->coupling->state().index_offset_m;
  return axis >= 0 && axis < o.size() ? o[axis] : 0.0;
}

double TeleopNode::max_clutch_force_rate_N_per_s() const noexcept {
  return impl_->coupling ? impl_->coupling->state().max_clutch_force_rate : 0.0;
}

namespace {

/// The check's verdict on `candidate` into `change` (limit, accepted, message); `what` prefixes the message.
void Check(const config::ProcessConfig& candidate, const std::string& what, TeleopNode::FixtureChange& change) {
  try {
    const config::StabilityReport report = config::CheckProcessStability(candidate);
    if (!report.applicable()) {
      change.message = what + "the stability check does not apply: " + report.not_applicable;
      return;
    }
    change.limit_N_per_m = report.worst().limit.max_stable_stiffness_N_per_m;
    change.accepted = report.stable();
    change.message =
        what + (change.accepted ? config::DescribePass(candidate, report) : config::DescribeFailure(candidate, report));
  } catch (const Error& e) {
    change.message = what + e.what();
  }
}

/// The largest |offset| of a plane move: the workspace's corner distance, sqrt(dof)·safety.max_abs_position_m (1000 m,
/// the key's maximum, when the check is off); any plane farther away is wholly outside a workspace.
double PlaneOffsetBound_m(const config::ProcessConfig& c) {
  const double box_m = c.safety.max_abs_position_m > 0.0 ? c.safety.max_abs_position_m : 1e3;
  return box_m * std::sqrt(static_cast<double>(c.dof));
}

const char* const kQueueFull = "; not applied: the cycle has not taken the pending commands (queue full)";

}  // namespace

TeleopNode::FixtureChange TeleopNode::RequestFixtureStiffness(double stiffness_N_per_m, double ramp_s) {
  Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.command_mutex);
  FixtureChange change;
  change.requested_N_per_m = stiffness_N_per_m;
  if (!std::isfinite(stiffness_N_per_m) || stiffness_N_per_m < 0.0) {
    change.message = "fixture stiffness must be finite and >= 0 N/m";
  } else if (s.check_base.law.fixture.plane_count == 0 && stiffness_N_per_m > 0.0) {
    change.message = "this process has no fixture plane";
  } else {
    config::ProcessConfig candidate = s.check_base;
    candidate.law.fixture.stiffness_N_per_m = stiffness_N_per_m;
    Check(candidate, "", change);
  }
  Impl::PendingCommand p;
  p.kind = change.accepted ? Event::Kind::kCommandAccepted : Event::Kind::kCommandRefused;
  p.value = change.accepted ? stiffness_N_per_m : change.limit_N_per_m;
  if (change.accepted) {
    p.change = Impl::PendingCommand::Change::kStiffness;
    p.stiffness_N_per_m = stiffness_N_per_m;
    p.ramp_s = std::isfinite(ramp_s) && ramp_s > 0.0 ? ramp_s : 0.0;
  }
  if (!s.Post(p) && change.accepted) {
    change.accepted = false;
    change.message += kQueueFull;
  } else if (change.accepted) {
    s.check_base.law.fixture.stiffness_N_per_m = stiffness_N_per_m;  // the next check's base
    if (stiffness_N_per_m > 0.0) s.fixture_on_N_per_m = stiffness_N_per_m;
  }
  return change;
}

TeleopNode::FixtureChange TeleopNode::RequestFixtureEnabled(bool on, double ramp_s) {
  double target = 0.0;
  if (on) {
    const std::lock_guard<std::mutex> lock(impl_->command_mutex);
    target = impl_->fixture_on_N_per_m;
  }
  if (on && target <= 0.0) {
    FixtureChange change;
    change.message = "no fixture stiffness to turn on (none configured or accepted yet)";
    RecordCommandEvent(Event::Kind::kCommandRefused, 0.0);
    return change;
  }
  return RequestFixtureStiffness(target, ramp_s);
}

TeleopNode::FixtureChange TeleopNode::RequestGain(GainName name, int axis, double value, double ramp_s) {
  Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.command_mutex);
  FixtureChange change;
  const int dof = s.check_base.dof;
  const std::string what = std::string("gain ") + ToString(name) +
                           (axis < 0 ? std::string() : "[" + std::to_string(axis) + "]") + " " + Num(value) + ": ";
  config::ProcessConfig candidate = s.check_base;
  control::ThreeChannelLaw::Config& law = candidate.law;
  DofVector* gain = name == GainName::kKp   ? &law.kp_N_per_m
                    : name == GainName::kKd ? &law.kd_Ns_per_m
                    : name == GainName::kKv ? &law.kv_Ns_per_m
                                            : &law.kf;
  if (axis < -1 || axis >= dof) {
    change.message = what + "axis " + std::to_string(axis) + " is outside 0.." + std::to_string(dof - 1);
  } else if (!std::isfinite(value) || (name != GainName::kKf && value < 0.0)) {
    change.message = what + "the gain must be finite" + (name != GainName::kKf ? " and >= 0" : "");
  } else if (name == GainName::kKf && s.check_base.role == Role::kSlave && value != 0.0) {
    change.message = what + "kf is the master's force feed-forward (eq. 8); the slave law (eq. 9) has none";
  } else {
    if (axis < 0) {
      gain->setConstant(value);
    } else {
      (*gain)[axis] = value;
    }
    try {
      config::RequireRenderable(candidate, s.device->capabilities(), s.device->name());
      Check(candidate, what, change);
    } catch (const Error& e) {
      change.message = what + e.what();
    }
  }
  Impl::PendingCommand p;
  p.kind = change.accepted ? Event::Kind::kGainAccepted : Event::Kind::kGainRefused;
  p.value = change.accepted ? value : change.limit_N_per_m;
  p.detail = GainDetail(name, axis);
  if (change.accepted) {
    p.change = Impl::PendingCommand::Change::kGains;
    p.ramp_s = std::isfinite(ramp_s) && ramp_s > 0.0 ? ramp_s : 0.0;
    const DofVector* gains[4] = {&law.kp_N_per_m, &law.kd_Ns_per_m, &law.kv_Ns_per_m, &law.kf};
    for (std::size_t g = 0; g < 4; ++g) {
      for (int i = 0; i < dof; ++i) p.gains[g][static_cast<std::size_t>(i)] = (*gains[g])[i];
    }
  }
  if (!s.Post(p) && change.accepted) {
    change.accepted = false;
    change.message += kQueueFull;
  } else if (change.accepted) {
    s.check_base.law = candidate.law;
  }
  return change;
}

TeleopNode::FixtureChange TeleopNode::RequestFixturePlane(const DofVector& normal, double offset_m,
                                                          double rate_m_per_s) {
  Impl& s = *impl_;
  const std::lock_guard<std::mutex> lock(s.command_mutex);
  FixtureChange change;
  const control::ForbiddenRegionFixture::Config& fixture = s.check_base.law.fixture;
  const int dof = s.check_base.dof;
  const double max_rate = fixture.max_offset_rate_m_per_s;
  const double rate = rate_m_per_s > 0.0 ? rate_m_per_s : max_rate;
  DofVector n = normal;
  if (fixture.plane_count == 0) {
    change.message = "this process has no fixture plane";
  } else if (normal.size() != dof) {
    change.message = "the normal needs dof = " + std::to_string(dof) + " entries, got " + std::to_string(normal.size());
  } else if (!AllFinite(normal) || !std::isfinite(offset_m) || !std::isfinite(rate_m_per_s)) {
    change.message = "the plane's offset, normal and rate must be finite";
  } else if (std::abs(offset_m) > PlaneOffsetBound_m(s.check_base)) {
    change.message = "offset " + Num(offset_m) + " m is outside +-" + Num(PlaneOffsetBound_m(s.check_base)) +
                     " m (safety.max_abs_position_m on every axis: a plane farther away is beyond the workspace)";
  } else if (!(normal.norm() > 1e-9)) {
    change.message = "the normal must not be zero (it points into the forbidden region)";
  } else if (rate > max_rate) {
    change.message = "rate " + Num(rate) + " m/s is above fixture.max_offset_rate_m_per_s " + Num(max_rate);
  } else {
    n /= n.norm();
    const control::FixturePlane& now = fixture.planes[0];
    if (dof == 1 && n[0] * now.normal[0] < 0.0) {
      change.message =
          "a 1-DOF plane cannot turn: its normal keeps its sign (flipping the forbidden side would step the force)";
    } else {
      const double normal_rate = fixture.max_normal_rate_rad_per_s * rate / max_rate;
      const std::string what = "fixture plane 0 to offset " + Num(offset_m) + " m: slewing at <= " + Num(rate) +
                               " m/s and " + Num(normal_rate) +
                               " rad/s (force rate <= K_VF * rate = " + Num(fixture.stiffness_N_per_m * rate) +
                               " N/s on a still device)";
      bool same_axes = true;  // the check sees the fixture on the axes the normal has a component on
      for (int i = 0; i < dof; ++i) same_axes = same_axes && ((n[i] != 0.0) == (now.normal[i] != 0.0));
      if (same_axes) {
        change.accepted = true;  // the analysis does not depend on where the plane is (eq. 7)
        change.message = what;
      } else {
        config::ProcessConfig candidate = s.check_base;  // every axis the slew passes through
        candidate.law.fixture.planes[0].normal = (now.normal.cwiseAbs() + n.cwiseAbs()).normalized();
        Check(candidate, what + "; ", change);
      }
    }
  }
  Impl::PendingCommand p;
  p.kind = change.accepted ? Event::Kind::kPlaneAccepted : Event::Kind::kPlaneRefused;
  p.value = change.accepted ? offset_m : 0.0;
  if (change.accepted) {
    p.change = Impl::PendingCommand::Change::kPlane;
    for (int i = 0; i < dof; ++i) p.normal[static_cast<std::size_t>(i)] = n[i];
    p.offset_m = offset_m;
    p.offset_rate_m_per_s = rate;
    p.normal_rate_rad_per_s = fixture.max_normal_rate_rad_per_s * rate / max_rate;
  }
  if (!s.Post(p) && change.accepted) {
    change.accepted = false;
    change.message += kQueueFull;
  } else if (change.accepted) {
    s.check_base.law.fixture.planes[0].normal = n;
    s.check_base.law.fixture.planes[0].offset_m = offset_m;
  }
  return change;
}

void TeleopNode::RecordCommandEvent(Event::Kind kind, double value) noexcept {
  Impl& s = *impl_;
  Impl::PendingCommand p;
  p.kind = kind;
  p.value = value;
  const std::lock_guard<std::mutex> lock(s.command_mutex);
  (void)s.Post(p);
}

std::uint64_t TeleopNode::command_events_dropped() const noexcept {
  return impl_->command_events_dropped.load(std::memory_order_relaxed);
}

int TeleopNode::dof() const noexcept { return impl_->config.dof; }

control::FixturePlane TeleopNode::fixture_plane(int index) const noexcept {
  if (!impl_->coupling) return {};
  const control::ForbiddenRegionFixture::Config& f = impl_->coupling->law().fixture().config();
  return index >= 0 && index < f.plane_count ? f.planes[static_cast<std::size_t>(index)] : control::FixturePlane{};
}

double TeleopNode::max_plane_offset_step_m() const noexcept {
  return impl_->coupling ? impl_->coupling->max_plane_offset_step_m() : 0.0;
}

double TeleopNode::max_plane_normal_step_rad() const noexcept {
  return impl_->coupling ? impl_->coupling->max_plane_normal_step_rad() : 0.0;
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

void TeleopNode::Impl::SummarizeLoop(RunSummary& summary, double wall_s) const {
  const auto& st = loop.stats();
  summary.role = config.role;
  summary.software_version = SoftwareVersion();  // operator (issue 30): the version in every summary
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
  summary.link_transport = config.link.transport;  // operator (issue 30): the round-trip line per transport
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
  // operator (issue 30): the clock of this side's telemetry and the peer's offset, for the session record
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
  summary.passivity_peer_without_energy = coupling->state().passivity_peer_without_energy;
  const EngagementMachine& m = coupling->engagement();
  EngagementSummary& e = summary.engagement;
  e.reaction = ToString(config.safety.reaction);
  e.final_state = ToString(m.state());
  e.times_engaged = m.engagements();
  e.couplings_lost = m.couplings_lost();
  e.engaged_cycles = r.engaged_cycles;
  e.aligning_mean_s = m.aligning_mean_s();
  e.aligning_max_s = m.aligning_max_s();
  e.max_reference_step_m = coupling->state().max_reference_step_m;
  e.max_aligning_force_rate_N_per_s = coupling->state().max_aligning_force_rate;
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
