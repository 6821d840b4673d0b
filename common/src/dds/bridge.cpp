#include "teleop/dds/bridge.hpp"

#include <dds/dds.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <ctime>
#include <limits>
#include <mutex>
#include <optional>
#include <thread>
#include <type_traits>

#include "dds_entities.hpp"
#include "teleop/dds/topic_names.hpp"
#include "teleop/error.hpp"
#include "teleop/runtime/background_thread.hpp"
#include "teleop/runtime/spsc_ring.hpp"
#include "teleop_msgs.h"

namespace teleop::dds {

namespace {

/// How long the bridge thread sleeps when both rings are empty: at 20 Hz state this is far below the state period.
constexpr auto kDrainInterval = std::chrono::milliseconds(5);
/// How long Stop() waits for reliable subscribers to acknowledge the last samples (the run summary).
constexpr dds_duration_t kAckTimeout = DDS_MSECS(1000);
constexpr std::size_t kEventRingCapacity = 256;

builtin_interfaces_msg_dds__Time_ WallClockNow() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return {static_cast<int32_t>(ts.tv_sec), static_cast<uint32_t>(ts.tv_nsec)};
}

/// The IDL's State arrays hold kStateAxes axes (one Cartesian device); a pair of more DOF (up to kMaxDof) shows its
/// first kStateAxes on DDS (docs/dds.md); the full vectors are in the telemetry CSV.
void CopyArray(const double (&in)[kMaxDof], double (&out)[kStateAxes]) noexcept {
  std::copy(std::begin(in), std::begin(in) + kStateAxes, std::begin(out));
}
static_assert(std::extent_v<decltype(teleop_msgs_msg_dds__State_::position_m)> == kStateAxes,
              "kStateAxes is the IDL's State array size");

/// The State's joint sequences are bounded by the one DOF limit: as many joints as a telemetry record carries.
static_assert(teleop_msgs_msg_dds__STATE_MAX_JOINTS == kMaxDof, "the IDL's STATE_MAX_JOINTS is teleop::kMaxDof");

/// A State joint sequence over `values` (the bridge thread's own copy; DDS only reads it while writing, so nothing
/// is allocated and nothing is released).
dds_sequence_double JointSequence(std::uint32_t joints, double* values) noexcept {
  dds_sequence_double seq{};
  seq._maximum = joints;
  seq._length = joints;
  seq._buffer = joints > 0 ? values : nullptr;
  seq._release = false;
  return seq;
}

/// DDS wants `char*` in the generated structs; it only reads them while writing.
char* Text(const std::string& s) noexcept { return const_cast<char*>(s.c_str()); }  // NOLINT

}  // namespace

const char* EventKindName(node::Event::Kind kind) noexcept {
  using Kind = node::Event::Kind;
  switch (kind) {
    case Kind::kPeerConnected:
      return "peer_connected";
    case Kind::kPeerLost:
      return "peer_lost";
    case Kind::kPeerRecovered:
      return "peer_recovered";
    case Kind::kPeerShutdown:
      return "peer_shutdown";
    case Kind::kPeerFault:
      return "peer_fault";
    case Kind::kDeviceFault:
      return "device_fault";
    case Kind::kDeviceFaultCleared:
      return "device_fault_cleared";
    case Kind::kNonFiniteInput:
      return "nonfinite_input";
    case Kind::kOverrun:
      return "overrun";
    case Kind::kNewSession:
      return "new_session";
    case Kind::kLatencyGate:
      return "latency_gate";
    case Kind::kCouplingLost:
      return "coupling_lost";
    case Kind::kAligning:
      return "aligning";
    case Kind::kEngaged:
      return "engaged";
    case Kind::kDeviceWarning:
      return "device_warning";
    case Kind::kClutchPressed:
      return "clutch_pressed";
    case Kind::kClutchReleased:
      return "clutch_released";
    case Kind::kReindexed:
      return "reindexed";
    case Kind::kCommandAccepted:
      return "command_accepted";
    case Kind::kCommandRefused:
      return "command_refused";
    case Kind::kCommandMalformed:
      return "command_malformed";
    case Kind::kCommandPeerRefused:
      return "command_peer_refused";
    case Kind::kClutchCommanded:
      return "clutch_commanded";
    case Kind::kGainAccepted:
      return "gain_accepted";
    case Kind::kGainRefused:
      return "gain_refused";
    case Kind::kPlaneAccepted:
      return "plane_accepted";
    case Kind::kPlaneRefused:
      return "plane_refused";
    case Kind::kDelayRecheck:
      return "delay_recheck";
    case Kind::kConfigurationLimit:
      return "configuration_limit";
  }
  return "unknown";
}

bool Bridge::Available() noexcept { return true; }

struct Bridge::Impl {
  Impl(const BridgeConfig& cfg, Role r, double rate_hz)
      : config(cfg),
        role(ToString(r)),
        loop_rate_hz(rate_hz),
        states(static_cast<std::size_t>(cfg.ring_capacity)),
        events(kEventRingCapacity),
        participant(cfg.domain_id),
        state_writer(participant, &teleop_msgs_msg_dds__State__desc, TopicName(cfg.pair, role, kStateLeaf),
                     WriterQos::kState),
        event_writer(participant, &teleop_msgs_msg_dds__Event__desc, TopicName(cfg.pair, role, kEventsLeaf),
                     WriterQos::kEvents),
        summary_writer(participant, &teleop_msgs_msg_dds__RunSummary__desc, TopicName(cfg.pair, role, kSummaryLeaf),
                       WriterQos::kSummary) {}

  void Run();
  bool DrainOnce();
  void WriteState(const BridgeSample& sample);
  void WriteEvent(const node::Event& event);

  BridgeConfig config;
  std::string role;
  double loop_rate_hz;
  runtime::SpscRing<BridgeSample> states;
  runtime::SpscRing<node::Event> events;
  Participant participant;
  Writer state_writer;
  Writer event_writer;
  Writer summary_writer;

  std::optional<BridgeSample> previous;  ///< For the achieved rate and the windowed loss.
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> states_published{0};
  std::atomic<std::uint64_t> states_dropped{0};
  std::atomic<std::uint64_t> events_published{0};
  std::atomic<std::uint64_t> events_dropped{0};
  std::atomic<std::uint64_t> write_errors{0};
  std::mutex stop_mutex;
  bool stopped = false;
  std::thread thread;
};

void Bridge::Impl::WriteState(const BridgeSample& s) {
  const runtime::TelemetryRecord& r = s.record;
  teleop_msgs_msg_dds__State_ msg{};
  msg.stamp = WallClockNow();
  msg.pair = Text(config.pair);
  msg.role = Text(role);
  msg.cycle = r.cycle;
  msg.time_s = r.time_s;
  msg.rate_hz = loop_rate_hz;
  msg.state_rate_hz = config.state_rate_hz;
  msg.achieved_rate_hz = std::numeric_limits<double>::quiet_NaN();
  msg.loss_fraction = std::numeric_limits<double>::quiet_NaN();
  if (previous && r.time_s > previous->record.time_s && r.cycle > previous->record.cycle) {
    msg.achieved_rate_hz = static_cast<double>(r.cycle - previous->record.cycle) / (r.time_s - previous->record.time_s);
    const std::uint64_t lost = s.link.lost - std::min(s.link.lost, previous->link.lost);
    const std::uint64_t accepted = s.link.accepted - std::min(s.link.accepted, previous->link.accepted);
    if (lost + accepted > 0) msg.loss_fraction = static_cast<double>(lost) / static_cast<double>(lost + accepted);
  }
  msg.engagement = static_cast<uint8_t>(s.engagement);
  msg.flags = r.flags;
  msg.device_faults = s.device_faults;
  msg.overruns = s.overruns;
  msg.watchdog_trips = s.watchdog_trips;
  msg.packets_sent = s.link.sent;
  msg.packets_received = s.link.received;
  msg.packets_accepted = s.link.accepted;
  msg.packets_lost = s.link.lost;
  msg.packets_reordered = s.link.reordered;
  msg.packets_rejected = s.link.rejected;
  msg.rtt_ms = r.rtt_s * 1e3;
  msg.dof = static_cast<uint8_t>(r.dof);
  CopyArray(r.position_m, msg.position_m);
  CopyArray(r.velocity_m_per_s, msg.velocity_m_per_s);
  CopyArray(r.force_sensor_N, msg.force_sensor_N);
  CopyArray(r.command_N, msg.command_N);
  CopyArray(r.peer_position_m, msg.peer_position_m);
  msg.fixture_penetration_m = r.fixture_penetration_m;
  msg.tracking_error_m = s.tracking_error_m;
  msg.clutch = static_cast<uint8_t>(r.clutch & 0xFF);
  msg.fixture_stiffness_N_per_m = r.fixture_stiffness_N_per_m;
  msg.fixture_limit_N_per_m = r.fixture_limit_N_per_m;  // NaN: no limit computed
  const auto joints = static_cast<std::uint32_t>(std::clamp(r.joints, 0, kMaxDof));
  std::array<double, kMaxDof> joint_position_rad{};
  std::array<double, kMaxDof> joint_torque_Nm{};
  std::copy_n(std::begin(r.joint_position_rad), joints, joint_position_rad.begin());
  std::copy_n(std::begin(r.joint_torque_Nm), joints, joint_torque_Nm.begin());
  msg.joint_position_rad = JointSequence(joints, joint_position_rad.data());
  msg.joint_torque_Nm = JointSequence(joints, joint_torque_Nm.data());
  if (state_writer.Write(&msg)) {
    states_published.fetch_add(1, std::memory_order_relaxed);
  } else {
    write_errors.fetch_add(1, std::memory_order_relaxed);
  }
  previous = s;
}

void Bridge::Impl::WriteEvent(const node::Event& e) {
  teleop_msgs_msg_dds__Event_ msg{};
  msg.stamp = WallClockNow();
  msg.pair = Text(config.pair);
  msg.role = Text(role);
  msg.cycle = e.cycle;
  msg.kind = static_cast<uint8_t>(e.kind);
  msg.kind_name = const_cast<char*>(EventKindName(e.kind));  // NOLINT: read only
  msg.value = e.value;
  if (event_writer.Write(&msg)) {
    events_published.fetch_add(1, std::memory_order_relaxed);
  } else {
    write_errors.fetch_add(1, std::memory_order_relaxed);
  }
}

bool Bridge::Impl::DrainOnce() {
  bool any = false;
  BridgeSample sample;
  while (states.TryPop(sample)) {
    WriteState(sample);
    any = true;
  }
  node::Event event;
  while (events.TryPop(event)) {
    WriteEvent(event);
    any = true;
  }
  return any;
}

void Bridge::Impl::Run() {
  while (true) {
    const bool stopping = stop.load(std::memory_order_acquire);
    const bool any = DrainOnce();
    if (stopping) break;
    if (!any) std::this_thread::sleep_for(kDrainInterval);
  }
}

Bridge::Bridge(const BridgeConfig& config, Role role, double loop_rate_hz) {
  if (!(config.state_rate_hz > 0.0) || !(loop_rate_hz > 0.0)) {
    throw Error("dds: state_rate_hz and the loop rate must be > 0");
  }
  decimation_ =
      std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::llround(loop_rate_hz / config.state_rate_hz)));
  impl_ = std::make_unique<Impl>(config, role, loop_rate_hz);
  impl_->thread = std::thread([impl = impl_.get()] {
    runtime::BecomeBackgroundThread("teleop-dds");
    impl->Run();
  });
  spdlog::info("dds: publishing on domain {} as rt/teleop/{}/{}/{{state,events,summary}}, state at {:.3g} Hz",
               config.domain_id, config.pair, impl_->role, loop_rate_hz / static_cast<double>(decimation_));
}

Bridge::~Bridge() {
  try {
    Stop();
  } catch (...) {
    // A destructor must not throw.
  }
}

bool Bridge::PushState(const BridgeSample& sample) noexcept {
  if (impl_->states.TryPush(sample)) return true;
  impl_->states_dropped.fetch_add(1, std::memory_order_relaxed);
  return false;
}

void Bridge::OnEvent(const node::Event& event) noexcept {
  if (!impl_->events.TryPush(event)) impl_->events_dropped.fetch_add(1, std::memory_order_relaxed);
}

void Bridge::PublishSummary(const node::RunSummary& s, const std::string& summary_json) {
  Impl& b = *impl_;
  teleop_msgs_msg_dds__RunSummary_ msg{};
  const std::string stop_reason = s.stop_reason;
  msg.stamp = WallClockNow();
  msg.pair = Text(b.config.pair);
  msg.role = Text(b.role);
  msg.stop_reason = Text(stop_reason);
  msg.duration_s = s.duration_s;
  msg.cycles = s.cycles;
  msg.achieved_rate_hz = s.achieved_rate_hz;
  msg.overruns = s.overruns;
  msg.packets_sent = s.link.sent;
  msg.packets_accepted = s.link.accepted;
  msg.packets_lost = s.link.lost;
  msg.packets_rejected = s.link.rejected;
  msg.watchdog_trips = s.watchdog_trips;
  msg.cycles_with_peer = s.cycles_with_peer;
  msg.rtt_p50_ms = s.rtt_ms.p50;
  msg.rtt_p99_ms = s.rtt_ms.p99;
  msg.rtt_max_ms = s.rtt_ms.max;
  msg.tracking_error_rms_m = s.tracking_error_rms_m;
  msg.fixture_max_penetration_m = s.fixture_max_penetration_m;
  msg.summary_json = Text(summary_json);
  if (!b.summary_writer.Write(&msg)) b.write_errors.fetch_add(1, std::memory_order_relaxed);
}

void Bridge::Stop() {
  if (!impl_) return;
  Impl& b = *impl_;
  const std::lock_guard<std::mutex> lock(b.stop_mutex);
  if (b.stopped) return;
  b.stopped = true;
  b.stop.store(true, std::memory_order_release);
  if (b.thread.joinable()) b.thread.join();
  // Reliable subscribers get the last state, the events and the summary before the participant goes.
  for (const Writer* w : {&b.state_writer, &b.event_writer, &b.summary_writer}) w->WaitForAcks(kAckTimeout);
  b.participant.Close();
  if (const auto d = b.states_dropped.load(); d > 0) {
    spdlog::warn("dds: {} state records dropped (ring of {} full); raise dds.ring_capacity", d, b.states.capacity());
  }
  if (const auto d = b.events_dropped.load(); d > 0) spdlog::warn("dds: {} events dropped (ring full)", d);
  if (const auto e = b.write_errors.load(); e > 0) spdlog::warn("dds: {} samples could not be written", e);
}

std::uint64_t Bridge::states_published() const noexcept { return impl_->states_published.load(); }
std::uint64_t Bridge::states_dropped() const noexcept { return impl_->states_dropped.load(); }
std::uint64_t Bridge::events_published() const noexcept { return impl_->events_published.load(); }
std::uint64_t Bridge::events_dropped() const noexcept { return impl_->events_dropped.load(); }

}  // namespace teleop::dds
