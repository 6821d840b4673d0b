// The node's stages through TeleopNode with a MockDevice: the passivity port integrates the command actually
// applied, the device's warnings reach every output, and the lifecycle (Configure / Activate / Deactivate) applies
// the real-time settings before the device is activated.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"
#include "teleop/node/teleop_node.hpp"
#include "teleop/transport/emulated_link.hpp"
#include "test_utilities/mock_device.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::node {
namespace {

using test::MockDevice;
using Call = MockDevice::Call;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

constexpr double kPeriod_s = 0.001;

std::string Config(const std::string& dir, const std::string& extra) {
  return R"(role: slave
dof: 1
rate_hz: 1000
link: {security: {mode: insecure}, bind: "127.0.0.1:47001", peer: "127.0.0.1:47002", timeout_ms: 100}
law: {kp_N_per_m: 600, kd_Ns_per_m: 0, max_force_N: 0}
device: {backend: loopback, loopback: {mass_kg: 0.04, damping_Ns_per_m: 0.41}}
stability: {check: false}
)" + std::string("safety: {reaction: zero_force, fault_record_dir: \"") +
         dir + "\"}\n" + extra;
}

std::unique_ptr<transport::Link> Link() {
  auto medium = std::make_shared<transport::EmulatedMedium>(transport::EmulatedMediumConfig{});
  return std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kSlave);
}

std::int64_t Ns(std::uint64_t cycle) { return 1'000'000'000 + static_cast<std::int64_t>(cycle) * 1'000'000; }

// Without a peer the slave is not coupled and reacts with zero_force: the law still computes the fixture's push
// (2000 N/m · 3..1 mm, along the motion out of the region: it would deliver energy), and the reaction replaces it with
// zero. The port must integrate the zero that was applied. Before the stages passed values, the port integrated the
// law's push (u·v > 0: delivered), so W went below zero every cycle (min -60 µJ) and the observer-mode controller
// "damped" a force that was never applied in 199 of the 200 cycles (both measured by running this test on the old
// order).
TEST(NodeStages, ThePassivityPortIntegratesTheCommandActuallyApplied) {
  test::ScopedTempDir dir("passivity-order");
  auto device = std::make_unique<MockDevice>(1);
  MockDevice* d = device.get();
  d->position_m << 0.008;
  TeleopNode node(
      config::ParseProcessConfig(Config(dir.path().string(),
                                        "fixture: {stiffness_N_per_m: 2000, half_space: {axis: 0, offset_m: 0.005}}\n"
                                        "passivity: {mode: observer, max_damping_Ns_per_m: 1000}\n"),
                                 "slave.yaml"),
      std::move(device), Link());
  double max_abs_command_N = 0.0;
  for (std::uint64_t k = 0; k < 200; ++k) {
    d->position_m[0] -= 1e-5;  // 10 mm/s out of the region: from 8 mm to 6 mm, still inside (x > 5 mm)
    node.Step(k, kPeriod_s, Ns(k));
    max_abs_command_N = std::max(max_abs_command_N, std::abs(d->last_command.force_N[0]));
  }
  const RunSummary summary = node.Finish();
  ASSERT_EQ(summary.engagement.final_state, "handshaking") << "no master: never coupled";
  EXPECT_EQ(d->writes, 200u);
  EXPECT_EQ(max_abs_command_N, 0.0) << "zero_force commands zero";
  EXPECT_EQ(summary.passivity_min_observed_J, 0.0) << "the port saw the zero it applied, not the law's push";
  EXPECT_EQ(summary.passivity_cycles, 0u) << "no damper for a force that was never applied";
  EXPECT_GT(summary.fixture_max_penetration_m, 0.0009) << "the law did compute the fixture's push";
}

/// Collects what reaches a sink: every cycle's warning word and every device-warning event.
class RecordingSink final : public CycleSink {
 public:
  struct Seen {
    std::vector<std::uint32_t> cycle_warnings;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> warning_events;
    std::vector<std::uint32_t> summary_last;
  };
  explicit RecordingSink(Seen& seen) : seen_(seen) { seen_.cycle_warnings.reserve(100); }
  void OnCycle(const CycleRecord& record) noexcept override {
    seen_.cycle_warnings.push_back(record.device_warnings);
    EXPECT_EQ(record.telemetry->device_warnings, record.device_warnings);
  }
  void OnEvent(const Event& event) noexcept override {
    if (event.kind != Event::Kind::kDeviceWarning) return;
    const std::lock_guard<std::mutex> lock(mutex_);
    seen_.warning_events.emplace_back(event.cycle, static_cast<std::uint32_t>(event.value));
  }
  void Publish(const RunSummary& summary) override { seen_.summary_last.push_back(summary.device_warnings.last); }

 private:
  Seen& seen_;
  std::mutex mutex_;
};

/// The warning word the test double raises at cycle k (of 40).
std::uint32_t WarningsAt(std::uint64_t k) {
  if (k >= 10 && k < 20) return device::kWarningStabilityGuard;
  if (k >= 30) return device::kWarningStabilityGuard | device::kWarningSaturated;
  return device::kWarningNone;
}

TEST(NodeStages, DeviceWarningsReachTheCsvTheEventsAndTheSummary) {
  test::ScopedTempDir dir("warnings");
  const std::string csv = dir.File("slave.csv");
  auto device = std::make_unique<MockDevice>(1);
  MockDevice* d = device.get();
  RecordingSink::Seen seen;
  {
    TeleopNode node(
        config::ParseProcessConfig(Config(dir.path().string(), "telemetry: {csv: \"" + csv + "\"}\n"), "slave.yaml"),
        std::move(device), Link(), TeleopNode::Unconfigured{});
    node.AddSink(std::make_unique<RecordingSink>(seen));
    node.Configure();
    node.Activate();
    for (std::uint64_t k = 0; k < 40; ++k) {
      d->warnings = WarningsAt(k);
      node.Step(k, kPeriod_s, Ns(k));
    }
    const RunSummary summary = node.Finish();
    EXPECT_EQ(summary.device_warnings.changes, 3u) << "0 → guard at 10, → 0 at 20, → guard|saturated at 30";
    EXPECT_EQ(summary.device_warnings.cycles, 20u);
    EXPECT_EQ(summary.device_warnings.seen, 3u);
    EXPECT_EQ(summary.device_warnings.last, 3u);
    EXPECT_THAT(FormatSummaryText(summary), HasSubstr("device warnings   3 changes, set in 20 cycles"));
    EXPECT_THAT(FormatSummaryJson(summary),
                HasSubstr(R"("device_warnings": {"changes": 3, "cycles": 20, "seen": 3, "last": 3})"));
    EXPECT_THROW(node.AddSink(std::make_unique<RecordingSink>(seen)), Error) << "only before Configure";
  }
  ASSERT_EQ(seen.cycle_warnings.size(), 40u);
  for (std::uint64_t k = 0; k < 40; ++k) EXPECT_EQ(seen.cycle_warnings[k], WarningsAt(k)) << "cycle " << k;
  using P = std::pair<std::uint64_t, std::uint32_t>;
  EXPECT_THAT(seen.warning_events, ElementsAre(P{10, 1}, P{20, 0}, P{30, 3})) << "one event per change";
  EXPECT_THAT(seen.summary_last, ElementsAre(3u)) << "the summary published once";
  // The CSV's device_warnings column, row by row (decimation 1).
  std::ifstream in(csv);
  std::string header;
  ASSERT_TRUE(std::getline(in, header));
  std::vector<std::string> names;
  std::stringstream hs(header);
  for (std::string name; std::getline(hs, name, ',');) names.push_back(name);
  const auto column = std::find(names.begin(), names.end(), "device_warnings") - names.begin();
  ASSERT_LT(static_cast<std::size_t>(column), names.size()) << header;
  std::uint64_t k = 0;
  for (std::string row; std::getline(in, row); ++k) {
    std::stringstream rs(row);
    std::string cell;
    for (std::ptrdiff_t c = 0; c <= column; ++c) std::getline(rs, cell, ',');
    EXPECT_EQ(cell, std::to_string(WarningsAt(k))) << "row " << k;
  }
  EXPECT_EQ(k, 40u);
}

/// An unconfigured slave node on a MockDevice whose calls the test reads; `node.reset()` destroys it.
struct UnconfiguredNode {
  UnconfiguredNode(const std::string& name, const std::string& extra) : dir(name) {
    auto d = std::make_unique<MockDevice>(1);
    device = d.get();
    device->deactivations = &deactivations;
    node = std::make_unique<TeleopNode>(config::ParseProcessConfig(Config(dir.path().string(), extra), "slave.yaml"),
                                        std::move(d), Link(), TeleopNode::Unconfigured{});
  }
  test::ScopedTempDir dir;
  int deactivations = 0;  ///< Declared before `node`: outlives it.
  MockDevice* device = nullptr;
  std::unique_ptr<TeleopNode> node;
};

TEST(NodeStages, TheLifecycleIsConfigureActivateDeactivate) {
  UnconfiguredNode n("lifecycle", "");
  MockDevice* d = n.device;
  TeleopNode& node = *n.node;
  EXPECT_EQ(d->calls(), 0u) << "nothing opened before Configure";
  EXPECT_THROW(node.Activate(), Error) << "Activate needs Configure";
  node.Configure();
  ASSERT_EQ(d->calls(), 1u);
  EXPECT_EQ(d->call(0), Call::kConfigure);
  node.Step(0, kPeriod_s, Ns(0));
  EXPECT_EQ(d->calls(), 1u) << "a configured, inactive node does not cycle";
  node.Activate();
  node.Step(1, kPeriod_s, Ns(1));
  node.Deactivate();
  node.Deactivate();
  node.Step(2, kPeriod_s, Ns(2));
  ASSERT_EQ(d->calls(), 6u);
  EXPECT_EQ(d->call(1), Call::kActivate);
  EXPECT_EQ(d->call(2), Call::kRead);
  EXPECT_EQ(d->call(3), Call::kWrite);
  EXPECT_EQ(d->call(4), Call::kUpdate);
  EXPECT_EQ(d->call(5), Call::kDeactivate);
  n.node.reset();
  EXPECT_EQ(n.deactivations, 1) << "once, not again when the node goes";
}

TEST(NodeStages, ARefusedRealtimeSettingNeverLeavesAnActiveDevice) {
  // realtime.cpu names a CPU this machine does not have: the affinity call fails in Activate, before the device's.
  UnconfiguredNode n("realtime", "realtime: {cpu: 1000}\n");
  n.node->Configure();
  try {
    n.node->Activate();
    FAIL() << "realtime.cpu 1000 was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("cpu 1000"));
  }
  n.node->Step(0, kPeriod_s, Ns(0));
  ASSERT_EQ(n.device->calls(), 1u) << "configured, never activated, never cycled";
  EXPECT_EQ(n.device->call(0), Call::kConfigure);
  n.node.reset();  // the device goes with the node
  EXPECT_EQ(n.deactivations, 0) << "never deactivated either: it was never active";
}

}  // namespace
}  // namespace teleop::node
