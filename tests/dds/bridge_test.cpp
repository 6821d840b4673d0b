// The bridge and the supervisor in one process over real Cyclone DDS on loopback (docs/dds.md): what the loop
// pushes arrives with the same figures, events and the summary arrive, a bridge that leaves shows as gone, and the
// loop-side call allocates nothing. Bounded waits; nothing is timed.
#include "teleop/dds/bridge.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "teleop/dds/supervisor.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "test_utilities/dds_test_domain.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::dds {
namespace {

constexpr auto kDiscoveryTimeout = std::chrono::seconds(15);

int TestDomain() { return test::LoopbackDdsDomain(0); }

BridgeConfig TestConfig(const std::string& pair) {
  BridgeConfig c;
  c.enabled = true;
  c.domain_id = TestDomain();
  c.pair = pair;
  c.state_rate_hz = 20.0;
  return c;
}

/// Polls until `done(view)` holds for the process (pair, role), at most kDiscoveryTimeout.
bool WaitFor(Supervisor& supervisor, const std::string& pair, const std::string& role,
             const std::function<bool(const ProcessView&)>& done, const std::function<void()>& each = {}) {
  const auto deadline = std::chrono::steady_clock::now() + kDiscoveryTimeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (each) each();
    supervisor.Poll();
    for (const ProcessView& v : supervisor.Snapshot(runtime::MonotonicNowNs())) {
      if (v.pair == pair && v.role == role && done(v)) return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

BridgeSample Sample(std::uint64_t cycle, double time_s, std::uint64_t accepted, std::uint64_t lost) {
  BridgeSample s;
  s.record.cycle = cycle;
  s.record.time_s = time_s;
  s.record.dof = 1;
  s.record.position_m[0] = 0.004;
  s.record.rtt_s = 0.0005;
  s.record.flags = 0x1;
  s.engagement = Engagement::kCoupled;
  s.link.accepted = accepted;
  s.link.lost = lost;
  s.tracking_error_m = 0.0002;
  return s;
}

TEST(Bridge, StateEventsAndSummaryArriveWithTheirFigures) {
  std::string event_seen;
  std::mutex traces_mutex;
  std::map<std::uint64_t, StateTrace> traces;  // the dashboard's trace of each State, by cycle
  Supervisor::Observer observer;
  observer.on_event = [&](const ProcessView&, const std::string& kind, std::uint64_t, double) { event_seen = kind; };
  observer.on_state = [&](const ProcessView&, const StateTrace& t) {
    const std::lock_guard<std::mutex> lock(traces_mutex);
    traces[t.cycle] = t;
  };
  Supervisor supervisor({TestDomain(), 1.0}, observer);
  Bridge bridge(TestConfig("bridge_test_a"), Role::kSlave, 1000.0);
  EXPECT_EQ(bridge.decimation(), 50U);  // 1000 Hz loop, 20 Hz state

  // Warm-up states (cycles below 1000) until the supervisor has matched and received one.
  std::uint64_t warmup = 0;
  ASSERT_TRUE(WaitFor(
      supervisor, "bridge_test_a", "slave", [](const ProcessView& v) { return v.have_state; },
      [&] {
        ++warmup;
        (void)bridge.PushState(Sample(warmup, 0.001 * static_cast<double>(warmup), warmup, 0));
      }));

  // Two known states: 50 cycles in 0.05 s = 1000 Hz; 2 lost of 50 in between = 4 % loss.
  ASSERT_TRUE(bridge.PushState(Sample(1000, 1.0, 990, 10)));
  BridgeSample b = Sample(1050, 1.05, 1038, 12);
  b.device_faults = 0x4;
  b.engagement = Engagement::kFault;
  b.watchdog_trips = 2;
  b.record.clutch = 2 | 4;  // the peer's flag and the command channel
  // An arm whose run-time limit lowered its fixture (docs/arms.md, "At run time"): 7 joints of kMaxDof.
  b.record.fixture_stiffness_N_per_m = 1400.0;
  b.record.fixture_limit_N_per_m = 14000.0;
  b.record.joints = 7;
  for (int j = 0; j < kMaxDof; ++j) {
    b.record.joint_position_rad[j] = j < 7 ? 0.1 * (j + 1) : 99.0;  // entries past `joints` are not sent
    b.record.joint_torque_Nm[j] = j < 7 ? -2.0 * (j + 1) : 99.0;
  }
  ASSERT_TRUE(bridge.PushState(b));
  ASSERT_TRUE(WaitFor(supervisor, "bridge_test_a", "slave", [](const ProcessView& v) { return v.cycle == 1050; }));
  const ProcessView v = supervisor.Snapshot(runtime::MonotonicNowNs()).front();
  EXPECT_EQ(v.status, ProcessView::Status::kLive);
  EXPECT_NEAR(v.achieved_rate_hz, 1000.0, 1e-6);
  EXPECT_NEAR(v.loss_fraction, 0.04, 1e-12);
  EXPECT_DOUBLE_EQ(v.rtt_ms, 0.5);
  EXPECT_DOUBLE_EQ(v.rate_hz, 1000.0);
  EXPECT_DOUBLE_EQ(v.state_rate_hz, 20.0);
  EXPECT_EQ(v.engagement, Engagement::kFault);
  EXPECT_EQ(v.device_faults, 0x4U);
  EXPECT_EQ(v.watchdog_trips, 2U);
  EXPECT_EQ(v.packets_lost, 12U);
  EXPECT_EQ(v.packets_accepted, 1038U);
  EXPECT_DOUBLE_EQ(v.tracking_error_m, 0.0002);
  EXPECT_EQ(v.clutch, 6U) << "the State's clutch sources";
  EXPECT_THAT(FormatTable({v}), ::testing::HasSubstr("peer+command"));
  EXPECT_DOUBLE_EQ(v.fixture_stiffness_N_per_m, 1400.0);
  EXPECT_DOUBLE_EQ(v.fixture_limit_N_per_m, 14000.0);
  ASSERT_EQ(v.joints, 7U);
  for (std::size_t j = 0; j < 7; ++j) {
    EXPECT_DOUBLE_EQ(v.joint_position_rad[j], 0.1 * static_cast<double>(j + 1)) << "joint " << j;
    EXPECT_DOUBLE_EQ(v.joint_torque_Nm[j], -2.0 * static_cast<double>(j + 1)) << "joint " << j;
  }
  EXPECT_THAT(FormatTable({v}), ::testing::HasSubstr(" 1400     14000 "));
  EXPECT_THAT(JsonStateLine(v, 1.0), ::testing::HasSubstr(R"("joint_torque_Nm":[-2,-4,-6,-8,-10,-12,-14])"));
  {
    const std::lock_guard<std::mutex> lock(traces_mutex);
    ASSERT_EQ(traces.count(1000), 1U);
    ASSERT_EQ(traces.count(1050), 1U);
    const StateTrace& before = traces[1000];
    const StateTrace& after = traces[1050];
    EXPECT_EQ(before.clutched, std::optional<bool>(false)) << "released: the dashboard shows released";
    EXPECT_EQ(after.clutched, std::optional<bool>(true)) << "clutched: the dashboard shows clutched";
    // A Cartesian record (the warm-up's): no fixture, no limit (NaN, not 0), no joints.
    EXPECT_DOUBLE_EQ(before.fixture_stiffness_N_per_m, 0.0);
    EXPECT_TRUE(std::isnan(before.fixture_limit_N_per_m)) << before.fixture_limit_N_per_m;
    EXPECT_EQ(before.joints, 0U);
    EXPECT_DOUBLE_EQ(after.fixture_stiffness_N_per_m, 1400.0);
    EXPECT_DOUBLE_EQ(after.fixture_limit_N_per_m, 14000.0);
    ASSERT_EQ(after.joints, 7U);
    EXPECT_DOUBLE_EQ(after.joint_position_rad[6], 0.7);
    EXPECT_DOUBLE_EQ(after.joint_torque_Nm[6], -14.0);
    EXPECT_DOUBLE_EQ(after.joint_position_rad[7], 0.0) << "only the joints sent";
  }

  bridge.OnEvent({node::Event::Kind::kPeerLost, 1049, 0.0});
  ASSERT_TRUE(
      WaitFor(supervisor, "bridge_test_a", "slave", [](const ProcessView& p) { return p.events_received > 0; }));
  EXPECT_EQ(event_seen, "peer_lost");

  node::RunSummary summary;
  summary.role = Role::kSlave;
  summary.cycles = 1051;
  summary.link.accepted = 1038;
  summary.link.lost = 12;
  summary.rtt_ms.p50 = 0.5;
  summary.rtt_ms.max = 0.9;
  summary.stop_reason = "signal";
  bridge.PublishSummary(summary, "{\"cycles\": 1051}");
  bridge.Stop();
  ASSERT_TRUE(WaitFor(supervisor, "bridge_test_a", "slave", [](const ProcessView& p) { return p.have_summary; }));
  const ProcessView end = supervisor.Snapshot(runtime::MonotonicNowNs()).front();
  EXPECT_EQ(end.status, ProcessView::Status::kFinished);
  EXPECT_EQ(end.stop_reason, "signal");
  EXPECT_EQ(end.summary_cycles, 1051U);
  EXPECT_EQ(end.summary_packets_lost, 12U);
  EXPECT_DOUBLE_EQ(end.summary_rtt_max_ms, 0.9);
  EXPECT_EQ(end.summary_json, "{\"cycles\": 1051}");
  EXPECT_EQ(bridge.states_dropped(), 0U);
}

// Anyone on the domain can publish (docs/security.md, "DDS"): text from a sample reaches the CSV record and the
// terminal only through SafeText, so it can neither add a CSV row or column nor move the cursor or clear the screen.
TEST(Supervisor, TextFromTheDomainCannotInjectRowsOrTerminalEscapes) {
  EXPECT_EQ(SafeText("peer_lost"), "peer_lost");
  EXPECT_EQ(SafeText("peer shutdown"), "peer shutdown");
  EXPECT_EQ(SafeText("a,b\n1,2,3\r\n"), "a?b?1?2?3??");
  EXPECT_EQ(SafeText("\x1b[2J\x1b[Hlive"), "?[2J?[Hlive");
  EXPECT_EQ(SafeText("\"q\" \\ \x7f \xc3\xa9"), "?q? ? ? ??");
  const std::string long_text(200, 'x');
  EXPECT_EQ(SafeText(long_text).size(), kMaxSafeTextLength);
  EXPECT_EQ(SafeText(long_text).substr(kMaxSafeTextLength - 3), "...");

  // End to end: a summary whose stop reason tries both.
  Supervisor supervisor({TestDomain(), 1.0});
  Bridge bridge(TestConfig("bridge_test_inject"), Role::kMaster, 1000.0);
  std::uint64_t cycle = 0;
  ASSERT_TRUE(WaitFor(
      supervisor, "bridge_test_inject", "master", [](const ProcessView& v) { return v.have_state; },
      [&] {
        ++cycle;
        (void)bridge.PushState(Sample(cycle, 0.001 * static_cast<double>(cycle), cycle, 0));
      }));
  node::RunSummary summary;
  summary.role = Role::kMaster;
  summary.stop_reason = "duration\n0,evil,row\x1b[2J";
  bridge.PublishSummary(summary, "{}");
  bridge.Stop();
  ASSERT_TRUE(WaitFor(supervisor, "bridge_test_inject", "master", [](const ProcessView& p) { return p.have_summary; }));
  for (const ProcessView& v : supervisor.Snapshot(runtime::MonotonicNowNs())) {
    if (v.pair == "bridge_test_inject") {
      EXPECT_EQ(v.stop_reason, "duration?0?evil?row?[2J");
    }
  }
}

// docs/dds.md lists every Event kind by number and name as the bridge publishes them (kind is the enum's value):
// a kind added without its line in the docs fails here.
TEST(Bridge, DocsListEveryEventKindWithItsNumber) {
  std::ifstream in(std::string(TELEOP_SOURCE_DIR) + "/docs/dds.md");
  ASSERT_TRUE(in) << "docs/dds.md";
  std::stringstream text;
  text << in.rdbuf();
  const std::string docs = text.str();
  int kinds = 0;
  for (int k = 0; k < 256; ++k) {  // the enum is uint8; EventKindName says "unknown" past the last kind
    const std::string name = EventKindName(static_cast<node::Event::Kind>(k));
    if (name == "unknown") break;
    ++kinds;
    EXPECT_NE(docs.find(" " + std::to_string(k) + " " + name), std::string::npos)
        << "docs/dds.md does not list kind " << k << " " << name;
  }
  EXPECT_GT(kinds, static_cast<int>(node::Event::Kind::kPlaneRefused));
}

// Anyone on the domain can add pairs: 2400 fake ones once took the supervisor from 9 to 124 MB. It follows the first
// max_pairs and counts the topics of the rest.
TEST(Supervisor, FollowsAtMostMaxPairs) {
  Supervisor::Config config{TestDomain(), 1.0};
  config.max_pairs = 2;
  Supervisor supervisor(config);
  std::vector<std::unique_ptr<Bridge>> bridges;
  for (const char* pair : {"bridge_test_bound_a", "bridge_test_bound_b", "bridge_test_bound_c"})
    bridges.push_back(std::make_unique<Bridge>(TestConfig(pair), Role::kMaster, 500.0));
  std::uint64_t cycle = 0;
  const auto push = [&] {
    cycle += 25;
    for (auto& b : bridges) (void)b->PushState(Sample(cycle, 0.001 * static_cast<double>(cycle), cycle, 0));
  };
  // Each bridge has three topics (state, events, summary): two pairs followed, the third's topics ignored.
  const auto deadline = std::chrono::steady_clock::now() + kDiscoveryTimeout;
  std::set<std::string> pairs;
  while (std::chrono::steady_clock::now() < deadline && (pairs.size() < 2 || supervisor.topics_ignored() < 3)) {
    push();
    supervisor.Poll();
    pairs.clear();
    for (const ProcessView& v : supervisor.Snapshot(runtime::MonotonicNowNs()))
      if (v.pair.rfind("bridge_test_bound_", 0) == 0) pairs.insert(v.pair);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(pairs.size(), 2U);
  EXPECT_EQ(supervisor.topics_ignored(), 3U);
}

TEST(Bridge, ABridgeThatLeavesWithoutASummaryIsGone) {
  Supervisor supervisor({TestDomain(), 1.0});
  auto bridge = std::make_unique<Bridge>(TestConfig("bridge_test_b"), Role::kMaster, 500.0);
  std::uint64_t cycle = 0;
  ASSERT_TRUE(WaitFor(
      supervisor, "bridge_test_b", "master", [](const ProcessView& v) { return v.have_state && v.writer_matched; },
      [&] {
        cycle += 25;
        (void)bridge->PushState(Sample(cycle, 0.001 * static_cast<double>(cycle), cycle, 0));
      }));
  bridge.reset();  // leaves the domain: the supervisor's reader loses its writer
  ASSERT_TRUE(WaitFor(supervisor, "bridge_test_b", "master",
                      [](const ProcessView& v) { return v.status == ProcessView::Status::kGone; }));
}

TEST(Bridge, PushStateAllocatesNothing) {
  BridgeConfig config = TestConfig("bridge_test_c");
  config.ring_capacity = 16;
  Bridge bridge(config, Role::kMaster, 1000.0);
  const BridgeSample s = Sample(1, 0.001, 1, 0);
  std::uint64_t allocations = 0;
  {
    test::AllocationCounter counter;
    for (int i = 0; i < 1000; ++i) (void)bridge.PushState(s);  // a full ring drops and counts, never allocates
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0U);
  bridge.Stop();
  EXPECT_EQ(bridge.states_published() + bridge.states_dropped(), 1000U);
}

}  // namespace
}  // namespace teleop::dds
