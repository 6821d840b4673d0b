#include "teleop/dds/supervisor.hpp"

#include <dds/dds.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <map>
#include <set>
#include <tuple>

#include "dds_entities.hpp"
#include "teleop/dds/log_limiter.hpp"
#include "teleop/dds/topic_names.hpp"
#include "teleop/error.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "teleop_msgs.h"

namespace teleop::dds {

namespace {

constexpr std::uint32_t kTakeBatch = 32;
/// Lines about what the domain sends (foreign types, pairs over the bound): at most one per this interval each.
constexpr std::int64_t kDomainLogInterval_ns = 10'000'000'000;

/// dds_take with loaned samples; calls `each(sample, info)` for every sample, then returns the loan.
template <typename Sample, typename Each>
void TakeAll(dds_entity_t reader, Each&& each) {
  std::array<void*, kTakeBatch> samples{};
  std::array<dds_sample_info_t, kTakeBatch> infos{};
  while (true) {
    samples.fill(nullptr);
    const dds_return_t n = dds_take(reader, samples.data(), infos.data(), kTakeBatch, kTakeBatch);
    if (n <= 0) return;
    for (dds_return_t i = 0; i < n; ++i) {
      const auto index = static_cast<std::size_t>(i);
      each(*static_cast<const Sample*>(samples[index]), infos[index]);
    }
    (void)dds_return_loan(reader, samples.data(), n);
    if (n < static_cast<dds_return_t>(kTakeBatch)) return;
  }
}

std::string Str(const char* s) { return s != nullptr ? std::string(s) : std::string(); }

/// The joints of a State: as many as both sequences hold (Cyclone refuses a sequence over its bound, kMaxDof; a
/// sample whose two sequences differ in length keeps the shorter), copied into `position` and `torque`.
std::uint8_t CopyJoints(const teleop_msgs_msg_dds__State_& s, std::array<double, kMaxDof>& position,
                        std::array<double, kMaxDof>& torque) noexcept {
  const dds_sequence_double& q = s.joint_position_rad;
  const dds_sequence_double& tau = s.joint_torque_Nm;
  if (q._buffer == nullptr || tau._buffer == nullptr) return 0;
  const std::size_t n = std::min<std::size_t>({q._length, tau._length, position.size()});
  std::copy_n(q._buffer, n, position.begin());
  std::copy_n(tau._buffer, n, torque.begin());
  std::fill(position.begin() + static_cast<std::ptrdiff_t>(n), position.end(), 0.0);
  std::fill(torque.begin() + static_cast<std::ptrdiff_t>(n), torque.end(), 0.0);
  return static_cast<std::uint8_t>(n);
}

/// The dashboard's traces of one State sample (the view already holds its pair, role and engagement).
StateTrace TraceOf(const teleop_msgs_msg_dds__State_& s, const ProcessView& v) {
  StateTrace t;
  t.pair = v.pair;
  t.role = v.role;
  t.cycle = s.cycle;
  t.time_s = s.time_s;
  t.engagement = v.engagement;
  t.device_faults = s.device_faults;
  t.dof = static_cast<std::uint8_t>(std::min<std::size_t>(s.dof, kStateAxes));
  for (std::size_t i = 0; i < t.dof; ++i) {
    t.position_m[i] = s.position_m[i];
    t.peer_position_m[i] = s.peer_position_m[i];
    t.force_sensor_N[i] = s.force_sensor_N[i];
    t.command_N[i] = s.command_N[i];
  }
  t.fixture_penetration_m = s.fixture_penetration_m;
  t.tracking_error_m = s.tracking_error_m;
  t.rtt_ms = s.rtt_ms;
  t.clutched = s.clutch != 0;
  t.fixture_stiffness_N_per_m = v.fixture_stiffness_N_per_m;
  t.fixture_limit_N_per_m = v.fixture_limit_N_per_m;
  t.joints = v.joints;
  t.joint_position_rad = v.joint_position_rad;
  t.joint_torque_Nm = v.joint_torque_Nm;
  return t;
}

}  // namespace

std::string SafeText(std::string_view text) {
  const bool cut = text.size() > kMaxSafeTextLength;
  std::string out(text.substr(0, cut ? kMaxSafeTextLength - 3 : text.size()));
  for (char& c : out) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte > 0x7E || c == ',' || c == '"' || c == '\\') c = '?';
  }
  if (cut) out += "...";
  return out;
}

struct Supervisor::Impl {
  struct Readers {
    dds_entity_t state = 0;
    dds_entity_t events = 0;
    dds_entity_t summary = 0;
  };

  Impl(const Config& cfg, Observer obs) : config(cfg), observer(std::move(obs)), participant(cfg.domain_id) {
    publications = Check(dds_create_reader(participant.handle(), DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr),
                         "cannot read the built-in publication topic");
  }

  void Discover();
  void Subscribe(const TopicParts& parts);
  void TakeStates(ProcessView& view, dds_entity_t reader);
  void TakeEvents(ProcessView& view, dds_entity_t reader);
  void TakeSummary(ProcessView& view, dds_entity_t reader);

  Config config;
  Observer observer;
  Participant participant;
  dds_entity_t publications = 0;
  std::map<std::tuple<std::string, std::string>, ProcessView> views;  ///< By (pair, role).
  std::map<std::tuple<std::string, std::string>, Readers> readers;
  std::set<std::string> subscribed;  ///< Topic names with a reader.
  std::set<std::string> pairs;       ///< Pairs followed (at most config.max_pairs).
  std::uint64_t topics_ignored = 0;
  LogLimiter type_log{kDomainLogInterval_ns};
  LogLimiter bound_log{kDomainLogInterval_ns};
};

void Supervisor::Impl::Subscribe(const TopicParts& parts) {
  const std::string name = TopicName(parts.pair, parts.role, parts.leaf);
  if (subscribed.count(name) != 0) return;
  if (pairs.count(parts.pair) == 0 && pairs.size() >= config.max_pairs) {
    ++topics_ignored;
    std::uint64_t suppressed = 0;
    if (bound_log.Allow(runtime::MonotonicNowNs(), suppressed))
      spdlog::warn("dds: {} ignored: already following {} pairs (--max-pairs); {} topics ignored so far", name,
                   config.max_pairs, topics_ignored);
    return;
  }
  pairs.insert(parts.pair);
  const dds_topic_descriptor_t* type = &teleop_msgs_msg_dds__State__desc;
  WriterQos qos_kind = WriterQos::kState;
  if (parts.leaf == kEventsLeaf) {
    type = &teleop_msgs_msg_dds__Event__desc;
    qos_kind = WriterQos::kEvents;
  } else if (parts.leaf == kSummaryLeaf) {
    type = &teleop_msgs_msg_dds__RunSummary__desc;
    qos_kind = WriterQos::kSummary;
  }
  const dds_entity_t topic = Check(dds_create_topic(participant.handle(), type, name.c_str(), nullptr, nullptr),
                                   "cannot create topic " + name);
  dds_qos_t* qos = MakeQos(qos_kind);
  const dds_entity_t reader = dds_create_reader(participant.handle(), topic, qos, nullptr);
  dds_delete_qos(qos);
  Check(reader, "cannot create a reader for " + name);
  subscribed.insert(name);
  const auto key = std::make_tuple(parts.pair, parts.role);
  ProcessView& view = views[key];
  view.pair = parts.pair;
  view.role = parts.role;
  Readers& r = readers[key];
  if (parts.leaf == kStateLeaf) r.state = reader;
  if (parts.leaf == kEventsLeaf) r.events = reader;
  if (parts.leaf == kSummaryLeaf) r.summary = reader;
}

void Supervisor::Impl::Discover() {
  std::vector<TopicParts> found;
  TakeAll<dds_builtintopic_endpoint_t>(
      publications, [&](const dds_builtintopic_endpoint_t& e, const dds_sample_info_t& info) {
        if (!info.valid_data) return;
        auto parts = ParseTopicName(Str(e.topic_name));
        if (!parts) return;
        const std::string type = Str(e.type_name);
        const std::string_view expected = parts->leaf == kStateLeaf    ? kStateTypeName
                                          : parts->leaf == kEventsLeaf ? kEventTypeName
                                                                       : kSummaryTypeName;
        if (type != expected) {
          std::uint64_t suppressed = 0;
          if (type_log.Allow(runtime::MonotonicNowNs(), suppressed))
            spdlog::warn("dds: {} carries type '{}', expected '{}': ignored ({} more such topics in the last {} s)",
                         SafeText(Str(e.topic_name)), SafeText(type), expected, suppressed,
                         kDomainLogInterval_ns / 1'000'000'000);
          return;
        }
        found.push_back(std::move(*parts));
      });
  for (const TopicParts& parts : found) Subscribe(parts);
}

void Supervisor::Impl::TakeStates(ProcessView& v, dds_entity_t reader) {
  TakeAll<teleop_msgs_msg_dds__State_>(reader, [&](const teleop_msgs_msg_dds__State_& s,
                                                   const dds_sample_info_t& info) {
    if (!info.valid_data) return;
    if (v.have_state && s.cycle < v.cycle) {
      // The process restarted under the same name: forget the previous run's end.
      v.have_summary = false;
      v.writer_left = false;
    }
    v.have_state = true;
    v.last_state_ns = runtime::MonotonicNowNs();
    ++v.states_received;
    v.cycle = s.cycle;
    v.time_s = s.time_s;
    v.rate_hz = s.rate_hz;
    v.achieved_rate_hz = s.achieved_rate_hz;
    v.state_rate_hz = s.state_rate_hz;
    v.loss_fraction = s.loss_fraction;
    v.rtt_ms = s.rtt_ms;
    v.engagement = s.engagement <= static_cast<uint8_t>(Engagement::kAligning) ? static_cast<Engagement>(s.engagement)
                                                                               : Engagement::kFault;
    v.flags = s.flags;
    v.device_faults = s.device_faults;
    v.overruns = s.overruns;
    v.watchdog_trips = s.watchdog_trips;
    v.packets_accepted = s.packets_accepted;
    v.packets_lost = s.packets_lost;
    v.packets_rejected = s.packets_rejected;
    v.tracking_error_m = s.tracking_error_m;
    v.fixture_penetration_m = s.fixture_penetration_m;
    v.clutch = s.clutch;
    v.fixture_stiffness_N_per_m = s.fixture_stiffness_N_per_m;
    v.fixture_limit_N_per_m = s.fixture_limit_N_per_m;
    v.joints = CopyJoints(s, v.joint_position_rad, v.joint_torque_Nm);
    if (observer.on_state) observer.on_state(v, TraceOf(s, v));
  });
  dds_subscription_matched_status_t matched{};
  if (dds_get_subscription_matched_status(reader, &matched) >= 0) {
    if (matched.current_count > 0) {
      v.writer_matched = true;
      v.writer_left = false;
    } else if (v.writer_matched) {
      v.writer_matched = false;
      v.writer_left = true;
    }
  }
}

void Supervisor::Impl::TakeEvents(ProcessView& v, dds_entity_t reader) {
  TakeAll<teleop_msgs_msg_dds__Event_>(reader,
                                       [&](const teleop_msgs_msg_dds__Event_& e, const dds_sample_info_t& info) {
                                         if (!info.valid_data) return;
                                         ++v.events_received;
                                         v.last_event = SafeText(Str(e.kind_name));
                                         if (observer.on_event) observer.on_event(v, v.last_event, e.cycle, e.value);
                                       });
}

void Supervisor::Impl::TakeSummary(ProcessView& v, dds_entity_t reader) {
  TakeAll<teleop_msgs_msg_dds__RunSummary_>(
      reader, [&](const teleop_msgs_msg_dds__RunSummary_& s, const dds_sample_info_t& info) {
        if (!info.valid_data) return;
        v.have_summary = true;
        v.stop_reason = SafeText(Str(s.stop_reason));
        v.summary_cycles = s.cycles;
        v.summary_packets_accepted = s.packets_accepted;
        v.summary_packets_lost = s.packets_lost;
        v.summary_rtt_p50_ms = s.rtt_p50_ms;
        v.summary_rtt_max_ms = s.rtt_max_ms;
        v.summary_json = Str(s.summary_json);
        if (observer.on_summary) observer.on_summary(v);
      });
}

Supervisor::Supervisor(const Config& config, Observer observer)
    : impl_(std::make_unique<Impl>(config, std::move(observer))) {}

Supervisor::~Supervisor() = default;

void Supervisor::Poll() {
  Impl& s = *impl_;
  s.Discover();
  for (auto& [key, readers] : s.readers) {
    ProcessView& view = s.views[key];
    // Summary first: a process that stopped is "finished", even if its last states arrive in the same poll.
    if (readers.summary != 0) s.TakeSummary(view, readers.summary);
    if (readers.state != 0) s.TakeStates(view, readers.state);
    if (readers.events != 0) s.TakeEvents(view, readers.events);
  }
}

std::vector<ProcessView> Supervisor::Snapshot(std::int64_t now_ns) const {
  std::vector<ProcessView> out;
  out.reserve(impl_->views.size());
  for (const auto& [key, view] : impl_->views) {
    ProcessView v = view;
    v.status = StatusOf(v, now_ns, impl_->config.stale_after_s);
    v.age_s =
        v.have_state ? static_cast<double>(now_ns - v.last_state_ns) * 1e-9 : std::numeric_limits<double>::quiet_NaN();
    out.push_back(std::move(v));
  }
  return out;
}

std::uint64_t Supervisor::topics_ignored() const noexcept { return impl_->topics_ignored; }

}  // namespace teleop::dds
