// Issue 19, defect 3, end to end: the cobot's eq 10 guard (`stability_action: warn`, the default) is seen in every
// output of the process, not only in Reading::warnings. The shipped master config (deploy/configs/cobot/
// master-udp.yaml) runs through TeleopNode with its lookahead cut from 50 mm to 2 mm: at the operator's 0.2 m/s and the
// 20 ms steering time constant, uτ = 4 mm > L, eq 11's bound is broken while the wall tracks, and the guard warns.
// With the shipped 50 mm (uτ = 4 mm < L = 50 mm) it never does. The node's sinks carry the word to the telemetry CSV
// (column device_warnings), the events (kDeviceWarning; the DDS sink publishes the same events as `device_warning`)
// and the summary (text and JSON).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
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
#include "test_utilities/temp_dir.hpp"

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
};

MasterRun RunMaster(const std::string& lookahead) {
  test::ScopedTempDir dir("cobot-warning");
  const std::string csv = dir.File("master.csv");
  std::string yaml = ShippedMaster();
  Replace(yaml, "lookahead_m: 0.05", "lookahead_m: " + lookahead);
  Replace(yaml, "csv: \"\"", "csv: \"" + csv + "\"");
  Replace(yaml, "lock_memory: true", "lock_memory: false");
  yaml += "safety: {fault_record_dir: \"" + dir.path().string() + "\"}\n";
  const config::ProcessConfig cfg = config::ParseProcessConfig(yaml, "master-udp.yaml");
  auto medium = std::make_shared<transport::EmulatedMedium>(transport::EmulatedMediumConfig{});
  MasterRun run;
  {
    TeleopNode node(cfg, device::MakeDevice(cfg.device),
                    std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kMaster),
                    TeleopNode::Unconfigured{});
    node.AddSink(std::make_unique<WarningEvents>(run.events));
    node.Configure();
    node.Activate();
    for (std::uint64_t k = 0; k < kCycles; ++k) {
      node.Step(k, kPeriod_s, 1'000'000'000 + static_cast<std::int64_t>(k) * 1'000'000);
    }
    run.summary = node.Finish();
  }
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
  const MasterRun unstable = RunMaster("0.002");
  EXPECT_EQ(unstable.csv_rows, kCycles);
  EXPECT_GT(unstable.summary.device_warnings.cycles, 100u) << "uτ = 4 mm > L = 2 mm along the wall: no warning";
  EXPECT_EQ(unstable.csv_rows_warning, unstable.summary.device_warnings.cycles) << "CSV and summary disagree";
  EXPECT_NE(unstable.summary.device_warnings.seen & device::kWarningStabilityGuard, 0u);
  ASSERT_FALSE(unstable.events.empty()) << "no device_warning event";
  EXPECT_NE(unstable.events.front() & device::kWarningStabilityGuard, 0u) << "the first change raises the guard";
  EXPECT_EQ(unstable.events.size(), unstable.summary.device_warnings.changes) << "one event per change";
  EXPECT_THAT(FormatSummaryText(unstable.summary), ::testing::HasSubstr("device warnings"));
  EXPECT_THAT(FormatSummaryJson(unstable.summary), ::testing::HasSubstr("\"device_warnings\": {\"changes\": "));

  const MasterRun stable = RunMaster("0.05");
  EXPECT_EQ(stable.summary.device_warnings.cycles, 0u) << "uτ = 4 mm < L = 50 mm warned";
  EXPECT_EQ(stable.csv_rows_warning, 0u);
  EXPECT_TRUE(stable.events.empty());
}

}  // namespace
}  // namespace teleop::node
