// An arm's telemetry (docs/arms.md, "Telemetry"): a node running the arm backend on the simulated 7-joint arm writes
// joint_position_rad_<i> and joint_torque_Nm_<i> for its 7 joints as the CSV's last columns, with the values the
// device read; the columns before them are those of every other device.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "arm_device.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/node/teleop_node.hpp"
#include "teleop/runtime/telemetry.hpp"
#include "teleop/transport/emulated_link.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::device::arm {
namespace {

const std::string kRobots = TELEOP_ROBOTS_DIR;
constexpr double kPeriod_s = 0.001;

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream in(line);
  for (std::string cell; std::getline(in, cell, ',');) cells.push_back(cell);
  return cells;
}

TEST(ArmTelemetry, TheCsvEndsWithEachJointsPositionAndTorque) {
  test::ScopedTempDir dir("arm-telemetry");
  const std::string csv = dir.File("slave.csv");
  std::string yaml = R"(role: slave
dof: 3
rate_hz: 1000
link: {security: {mode: insecure}, bind: "127.0.0.1:47001", peer: "127.0.0.1:47002", timeout_ms: 10000}
law: {kp_N_per_m: 300, kd_Ns_per_m: 2, max_force_N: 40}
stability: {check: false}
device:
  backend: arm
  arm:
    base_link: base
    tool_link: tool
    actuators: simulated
    simulation: {initial_q_rad: [0, 0.6, 0, -1.4, 0, 0.9, 0], viscous_Nms_per_rad: 0.5}
)";
  yaml += "    urdf: " + kRobots + "/arm_7dof.urdf\n";
  yaml += "telemetry: {csv: \"" + csv + "\", ring_capacity: 256}\n";
  yaml += "safety: {fault_record_dir: \"" + dir.path().string() + "\"}\n";
  const config::ProcessConfig config = config::ParseProcessConfig(yaml, "arm-telemetry.yaml");
  std::unique_ptr<Device> device = MakeDevice(config.device);
  auto* arm = dynamic_cast<ArmDevice*>(device.get());
  ASSERT_NE(arm, nullptr);
  EXPECT_EQ(arm->capabilities().joints, 7);
  auto medium = std::make_shared<transport::EmulatedMedium>(transport::EmulatedMediumConfig{});
  node::TeleopNode node(config, std::move(device),
                        std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kSlave));
  // No peer: the arm is in its safe state and holds its weight, τ = G(q). After each cycle: q as the device read it
  // and the torque it applied, which the simulated actuators report at the next cycle's read.
  constexpr int kCycles = 50;
  std::vector<JointVector> q(kCycles), applied(kCycles);
  for (int k = 0; k < kCycles; ++k) {
    node.Step(static_cast<std::uint64_t>(k), kPeriod_s, 1'000'000'000 + std::int64_t{k} * 1'000'000);
    medium->Advance(kPeriod_s);
    q[static_cast<std::size_t>(k)] = arm->q();
    applied[static_cast<std::size_t>(k)] = arm->torque().terms().applied_Nm;
  }
  (void)node.Finish();

  std::ifstream in(csv);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  const std::vector<std::string> header = Split(line);
  EXPECT_EQ(line, runtime::TelemetryCsvHeader(3, 7));
  // The task-space columns are a Cartesian device's, the joint columns follow them.
  ASSERT_EQ(line.rfind(runtime::TelemetryCsvHeader(3), 0), 0u) << line;
  std::map<std::string, std::size_t> column;
  for (std::size_t c = 0; c < header.size(); ++c) column[header[c]] = c;
  for (int i = 0; i < 7; ++i) {
    ASSERT_EQ(column.count("joint_position_rad_" + std::to_string(i)), 1u) << i;
    ASSERT_EQ(column.count("joint_torque_Nm_" + std::to_string(i)), 1u) << i;
  }
  EXPECT_EQ(header.back(), "joint_torque_Nm_6");
  EXPECT_EQ(column.count("joint_position_rad_7"), 0u);

  int rows = 0;
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = Split(line);
    ASSERT_EQ(cells.size(), header.size()) << line;
    const auto k = static_cast<std::size_t>(std::stoull(cells[column["cycle"]]));
    ASSERT_LT(k, static_cast<std::size_t>(kCycles));
    for (int i = 0; i < 7; ++i) {
      const double position = std::stod(cells[column["joint_position_rad_" + std::to_string(i)]]);
      const double torque = std::stod(cells[column["joint_torque_Nm_" + std::to_string(i)]]);
      EXPECT_EQ(position, q[k][i]) << "cycle " << k << " joint " << i;
      if (k > 0) {
        EXPECT_EQ(torque, applied[k - 1][i]) << "cycle " << k << " joint " << i;
      }
    }
    // The shoulder (joint 2) carries the arm's weight: a real torque, not a column of zeros.
    if (k > 0) {
      EXPECT_GT(std::abs(std::stod(cells[column["joint_torque_Nm_1"]])), 1.0) << "cycle " << k;
    }
    ++rows;
  }
  EXPECT_EQ(rows, kCycles);
}

}  // namespace
}  // namespace teleop::device::arm
