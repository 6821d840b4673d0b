// Issue 19, defect 3, end to end: the cobot's eq 10 guard (`stability_action: warn`, the default) is seen in every
// output of the process, not only in Reading::warnings. The shipped master config (deploy/configs/cobot/
// master-udp.yaml) runs through TeleopNode with its lookahead cut from 50 mm to 2 mm: at the operator's 0.2 m/s and the
// 20 ms steering time constant, uτ = 4 mm > L, eq 11's bound is broken while the wall tracks, and the guard warns.
// With the shipped 50 mm (uτ = 4 mm < L = 50 mm) it never does. The node's sinks carry the word to the telemetry CSV
// (column device_warnings), the events (kDeviceWarning), the summary (text and JSON) and, in a build with DDS, the
// DDS event stream (`device_warning` on rt/teleop/<pair>/master/events, read by the supervisor over Cyclone DDS on
// loopback) and the DDS run summary.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/config/yaml_config.hpp"
#include "teleop/device/device.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/node/cycle_sink.hpp"
#include "teleop/node/teleop_node.hpp"
#include "teleop/transport/emulated_link.hpp"
#include "test_utilities/dds_test_domain.hpp"
#include "test_utilities/temp_dir.hpp"

#if TELEOP_TEST_DDS
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <thread>

#include "teleop/dds/supervisor.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#endif

namespace teleop::node {
namespace {

constexpr double kPeriod_s = 0.001;
constexpr std::uint64_t kCycles = 2500;  // the push meets the plane at about 0.8 s and turns away at 2 s

std::string ShippedMaster() {
  std::ifstream in(std::string(TELEOP_SOURCE_DIR) + "/deploy/configs/cobot/master-udp.yaml");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void Replace(std::string& text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  ASSERT_NE(at, std::string::npos) << "the shipped config no longer has '" << from << "'";
  text.replace(at, from.size(), to);
}

/// Collects the device-warning events a sink is given.
class WarningEvents final : public CycleSink {
 public:
  explicit WarningEvents(std::vector<std::uint32_t>& words) : words_(words) { words_.reserve(4096); }
  void OnCycle(const CycleRecord& /*record*/) noexcept override {}
  // The event log's thread; the test reads the words after the node is gone.
  void OnEvent(const Event& event) noexcept override {
    if (event.kind != Event::Kind::kDeviceWarning) return;
    const std::lock_guard<std::mutex> lock(mutex_);
    if (words_.size() < words_.capacity()) words_.push_back(static_cast<std::uint32_t>(event.value));
  }

 private:
  std::mutex mutex_;
  std::vector<std::uint32_t>& words_;
};

struct MasterRun {
  RunSummary summary;
  std::vector<std::uint32_t> events;
  std::uint64_t csv_rows_warning = 0;
  std::uint64_t csv_rows = 0;
  // Over DDS (a build with TELEOP_DDS): the device_warning events the supervisor received, and the summary's JSON.
  bool dds = false;
  std::vector<std::uint32_t> dds_events;
  std::string dds_summary_json;
};

#if TELEOP_TEST_DDS
constexpr auto kDiscoveryTimeout = std::chrono::seconds(15);

int TestDomain() { return test::LoopbackDdsDomain(40); }

/// Polls the supervisor until `done(view)` holds for the pair's master, at most kDiscoveryTimeout.
bool WaitFor(dds::Supervisor& supervisor, const std::string& pair,
             const std::function<bool(const dds::ProcessView&)>& done) {
  const auto deadline = std::chrono::steady_clock::now() + kDiscoveryTimeout;
  while (std::chrono::steady_clock::now() < deadline) {
    supervisor.Poll();
    for (const dds::ProcessView& v : supervisor.Snapshot(runtime::MonotonicNowNs())) {
      if (v.pair == pair && v.role == "master" && done(v)) return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}
#endif

MasterRun RunMaster(const std::string& lookahead, bool with_dds = false) {
  test::ScopedTempDir dir("cobot-warning");
  const std::string csv = dir.File("master.csv");
  std::string yaml = ShippedMaster();
  Replace(yaml, "lookahead_m: 0.05", "lookahead_m: " + lookahead);
  Replace(yaml, "csv: \"\"", "csv: \"" + csv + "\"");
  Replace(yaml, "lock_memory: true", "lock_memory: false");
  yaml += "safety: {fault_record_dir: \"" + dir.path().string() + "\"}\n";
  MasterRun run;
#if TELEOP_TEST_DDS
  const std::string pair = "cobot_warning_" + std::to_string(getpid());
  std::unique_ptr<dds::Supervisor> supervisor;
  if (with_dds) {
    run.dds = true;
    yaml += "dds: {enabled: true, domain_id: " + std::to_string(TestDomain()) + ", pair: " + pair + "}\n";
    dds::Supervisor::Observer observer;
    observer.on_event = [&run](const dds::ProcessView&, const std::string& kind, std::uint64_t, double value) {
      if (kind == "device_warning") run.dds_events.push_back(static_cast<std::uint32_t>(value));
    };
    supervisor = std::make_unique<dds::Supervisor>(dds::Supervisor::Config{TestDomain(), 1.0}, observer);
  }
#else
  (void)with_dds;
#endif
  const config::ProcessConfig cfg = config::ParseProcessConfig(yaml, "master-udp.yaml");
  auto medium = std::make_shared<transport::EmulatedMedium>(transport::EmulatedMediumConfig{});
  {
    TeleopNode node(cfg, device::MakeDevice(cfg.device),
                    std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kMaster),
                    TeleopNode::Unconfigured{});
    node.AddSink(std::make_unique<WarningEvents>(run.events));
    node.Configure();
    node.Activate();
#if TELEOP_TEST_DDS
    // The State and Events topics are volatile: what is written before the writers know the supervisor's readers is
    // lost, and cycle 0 writes the only State until simulated time moves. Wait until the supervisor's State reader
    // has matched the bridge's writer, then give the other direction (the writers learning of the readers; the
    // three topics are discovered together) a moment: under the sanitizers discovery is slower than Configure.
    if (supervisor) {
      EXPECT_TRUE(WaitFor(*supervisor, pair, [](const dds::ProcessView& v) { return v.writer_matched; }))
          << "the supervisor never discovered the master's writers";
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
#endif
    for (std::uint64_t k = 0; k < kCycles; ++k) {
      node.Step(k, kPeriod_s, 1'000'000'000 + static_cast<std::int64_t>(k) * 1'000'000);
#if TELEOP_TEST_DDS
      // The events topic is volatile: the supervisor must have matched before the first warning (about 0.8 s in).
      // Cycle 0 publishes a State; wait until it arrived (the three topics are discovered together). Simulated time
      // does not advance while the test waits.
      if (supervisor && k == 0) {
        EXPECT_TRUE(WaitFor(*supervisor, pair, [](const dds::ProcessView& v) { return v.have_state; }))
            << "the supervisor never saw the master's State";
      }
      if (supervisor && k % 50 == 0) supervisor->Poll();
#endif
    }
    run.summary = node.Finish();
  }
#if TELEOP_TEST_DDS
  if (supervisor) {
    EXPECT_TRUE(WaitFor(*supervisor, pair, [&run](const dds::ProcessView& v) {
      if (v.have_summary) run.dds_summary_json = v.summary_json;
      return v.have_summary;
    })) << "no run summary over DDS";
  }
#endif
  std::ifstream in(csv);
  std::string header;
  EXPECT_TRUE(std::getline(in, header)) << csv;
  std::vector<std::string> names;
  std::stringstream hs(header);
  for (std::string name; std::getline(hs, name, ',');) names.push_back(name);
  const auto column = std::find(names.begin(), names.end(), "device_warnings") - names.begin();
  EXPECT_LT(static_cast<std::size_t>(column), names.size()) << header;
  for (std::string row; std::getline(in, row);) {
    std::stringstream rs(row);
    std::string cell;
    for (std::ptrdiff_t c = 0; c <= column; ++c) std::getline(rs, cell, ',');
    ++run.csv_rows;
    if ((std::stoul(cell) & device::kWarningStabilityGuard) != 0) ++run.csv_rows_warning;
  }
  return run;
}

TEST(CobotNode, TheStabilityGuardsWarningReachesTheCsvTheEventsAndTheSummary) {
  const MasterRun unstable = RunMaster("0.002", /*with_dds=*/true);
  EXPECT_EQ(unstable.csv_rows, kCycles);
  EXPECT_GT(unstable.summary.device_warnings.cycles, 100u) << "uτ = 4 mm > L = 2 mm along the wall: no warning";
  EXPECT_EQ(unstable.csv_rows_warning, unstable.summary.device_warnings.cycles) << "CSV and summary disagree";
  EXPECT_NE(unstable.summary.device_warnings.seen & device::kWarningStabilityGuard, 0u);
  ASSERT_FALSE(unstable.events.empty()) << "no device_warning event";
  EXPECT_NE(unstable.events.front() & device::kWarningStabilityGuard, 0u) << "the first change raises the guard";
  EXPECT_EQ(unstable.events.size(), unstable.summary.device_warnings.changes) << "one event per change";
  EXPECT_THAT(FormatSummaryText(unstable.summary), ::testing::HasSubstr("device warnings"));
  EXPECT_THAT(FormatSummaryJson(unstable.summary), ::testing::HasSubstr("\"device_warnings\": {\"changes\": "));

  if (unstable.dds) {
    // The DDS event stream: the same events, named device_warning, the first raising the guard's bit. The events
    // topic keeps the last 100 per reader, so at most as many as the node logged arrive.
    ASSERT_FALSE(unstable.dds_events.empty()) << "no device_warning event over DDS";
    EXPECT_NE(unstable.dds_events.front() & device::kWarningStabilityGuard, 0u);
    EXPECT_LE(unstable.dds_events.size(), unstable.events.size());
    EXPECT_EQ(unstable.dds_events.front(), unstable.events.front());
    // The DDS run summary carries the same device_warnings object as --summary-json.
    const std::string expected =
        "\"device_warnings\": {\"changes\": " + std::to_string(unstable.summary.device_warnings.changes) +
        ", \"cycles\": " + std::to_string(unstable.summary.device_warnings.cycles);
    EXPECT_THAT(unstable.dds_summary_json, ::testing::HasSubstr(expected));
  }

  const MasterRun stable = RunMaster("0.05");
  EXPECT_EQ(stable.summary.device_warnings.cycles, 0u) << "uτ = 4 mm < L = 50 mm warned";
  EXPECT_EQ(stable.csv_rows_warning, 0u);
  EXPECT_TRUE(stable.events.empty());
}

}  // namespace
}  // namespace teleop::node
