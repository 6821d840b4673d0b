#include "teleop/runtime/telemetry.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::runtime {
namespace {

namespace fs = std::filesystem;

class TelemetryWriterTest : public ::testing::Test {
 protected:
  static std::vector<std::string> ReadLines(const fs::path& path) {
    std::ifstream in(path);
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
  }

  test::ScopedTempDir temp_{"telemetry"};
  const fs::path& dir_ = temp_.path();
};

TelemetryRecord MakeRecord(std::uint64_t cycle, int dof) {
  TelemetryRecord r{};
  r.cycle = cycle;
  r.time_s = static_cast<double>(cycle) * 1e-3;
  r.dof = dof;
  for (int i = 0; i < dof; ++i) {
    r.position_m[i] = 0.25 * (i + 1);
    r.velocity_m_per_s[i] = -0.5;
    r.force_sensor_N[i] = 3.0;
    r.command_N[i] = -1.5;
    r.rendered_force_N[i] = -1.25;
    r.fixture_force_N[i] = 0.0;
    r.peer_position_m[i] = 0.125;
    r.peer_velocity_m_per_s[i] = 2.0;
    r.peer_force_N[i] = -4.0;
  }
  r.fixture_penetration_m = 0.001;
  r.law_status = 1;
  r.flags = 9;
  r.compute_s = 2.5e-5;
  for (int i = 0; i < dof; ++i) {
    r.passivity_observed_J[i] = 0.125 * (i + 1);
    r.passivity_damping_Ns_per_m[i] = 4.0;
  }
  r.engagement = 3;
  r.data_age_s = 3e-5;
  r.device_warnings = 1;  // device::kWarningStabilityGuard
  r.fixture_stiffness_N_per_m = 1500.0;
  r.fixture_limit_N_per_m = 14057.5;
  return r;
}

TEST(TelemetryCsv, HeaderCarriesUnitsInColumnNames) {
  EXPECT_EQ(TelemetryCsvHeader(1),
            "cycle,time_s,dof,position_m_0,velocity_m_per_s_0,force_sensor_N_0,command_N_0,rendered_force_N_0,"
            "fixture_force_N_0,"
            "peer_position_m_0,peer_velocity_m_per_s_0,peer_force_N_0,fixture_penetration_m,law_status,flags,rtt_s,"
            "compute_s,engagement,data_age_s,passivity_observed_J_0,passivity_damping_Ns_per_m_0,device_warnings,"
            "clutch,fixture_stiffness_N_per_m,fixture_limit_N_per_m");
  const std::string two = TelemetryCsvHeader(2);
  EXPECT_NE(two.find("position_m_0,position_m_1,velocity_m_per_s_0"), std::string::npos) << two;
}

TEST(TelemetryCsv, GoldenRow) {
  TelemetryRecord r = MakeRecord(7, 2);
  r.rtt_s = 0.0015;
  EXPECT_EQ(TelemetryCsvRow(r, 2),
            "7,0.007,2,0.25,0.5,-0.5,-0.5,3,3,-1.5,-1.5,-1.25,-1.25,0,0,0.125,0.125,2,2,-4,-4,0.001,1,9,0.0015,2.5e-05,"
            "3,3e-05,"
            "0.125,0.25,4,4,1,0,1500,14057.5");
  r.rtt_s = std::numeric_limits<double>::quiet_NaN();
  const std::string row = TelemetryCsvRow(r, 1);
  EXPECT_EQ(row, "7,0.007,2,0.25,-0.5,3,-1.5,-1.25,0,0.125,2,-4,0.001,1,9,nan,2.5e-05,3,3e-05,0.125,4,1,0,1500,14057.5")
      << "NaN RTT written as nan";
}

TEST(TelemetryCsv, JointColumnsComeLastAndOnlyForADeviceMadeOfJoints) {
  // A Cartesian device (joints 0): the columns it always had, none of a joint.
  EXPECT_EQ(TelemetryCsvHeader(2, 0), TelemetryCsvHeader(2));
  EXPECT_EQ(TelemetryCsvHeader(2).find("joint_"), std::string::npos);
  const std::string header = TelemetryCsvHeader(1, 2);
  EXPECT_EQ(header,
            TelemetryCsvHeader(1) + ",joint_position_rad_0,joint_position_rad_1,joint_torque_Nm_0,joint_torque_Nm_1");
  TelemetryRecord r = MakeRecord(7, 1);
  r.rtt_s = 0.0015;
  r.joints = 2;
  r.joint_position_rad[0] = 0.5;
  r.joint_position_rad[1] = -1.25;
  r.joint_torque_Nm[0] = 12.5;
  r.joint_torque_Nm[1] = -0.75;
  r.joint_position_rad[2] = 99.0;  // beyond the device's joints: not written
  EXPECT_EQ(TelemetryCsvRow(r, 1, 2), TelemetryCsvRow(r, 1) + ",0.5,-1.25,12.5,-0.75");
  EXPECT_EQ(TelemetryCsvRow(r, 1, 0), TelemetryCsvRow(r, 1));
}

TEST_F(TelemetryWriterTest, TakesTheJointsFromTheFirstRecordWithTheDof) {
  const fs::path path = dir_ / "joints.csv";
  {
    TelemetryWriter writer(path.string(), 16);
    TelemetryRecord r = MakeRecord(0, 1);
    r.joints = 3;
    r.joint_torque_Nm[2] = 4.0;
    ASSERT_TRUE(writer.Push(r));
  }
  const auto lines = ReadLines(path);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], TelemetryCsvHeader(1, 3));
  // fixture_stiffness_N_per_m, fixture_limit_N_per_m, then 3 positions and 3 torques
  const std::string tail = ",1500,14057.5,0,0,0,0,0,4";
  ASSERT_GT(lines[1].size(), tail.size());
  EXPECT_EQ(lines[1].substr(lines[1].size() - tail.size()), tail) << lines[1];
}

TEST_F(TelemetryWriterTest, WritesHeaderAndOneRowPerPushedRecordInOrder) {
  const fs::path path = dir_ / "run.csv";
  TelemetryWriter writer(path.string(), 64, 2);
  constexpr std::uint64_t kRecords = 50;
  for (std::uint64_t c = 0; c < kRecords; ++c) ASSERT_TRUE(writer.Push(MakeRecord(c, 2)));
  writer.Stop();
  EXPECT_EQ(writer.pushed(), kRecords);
  EXPECT_EQ(writer.written(), kRecords);
  EXPECT_EQ(writer.dropped(), 0u);
  EXPECT_EQ(writer.write_errors(), 0u);

  const auto lines = ReadLines(path);
  ASSERT_EQ(lines.size(), kRecords + 1);
  EXPECT_EQ(lines[0], TelemetryCsvHeader(2));
  for (std::uint64_t c = 0; c < kRecords; ++c) {
    EXPECT_EQ(lines[c + 1], TelemetryCsvRow(MakeRecord(c, 2), 2));
  }
  // Parse one row back: column count matches the header, values are the physical quantities pushed.
  std::stringstream row(lines[3]);
  std::vector<double> values;
  for (std::string cell; std::getline(row, cell, ',');) values.push_back(std::stod(cell));
  // ..., device_warnings, clutch, fixture_stiffness_N_per_m, fixture_limit_N_per_m.
  ASSERT_EQ(values.size(), 3u + 9u * 2u + 7u + 2u * 2u + 4u);
  EXPECT_DOUBLE_EQ(values[values.size() - 2], 1500.0);  // fixture_stiffness_N_per_m
  EXPECT_DOUBLE_EQ(values.back(), 14057.5);             // fixture_limit_N_per_m
  EXPECT_EQ(values[0], 2.0);                            // cycle
  EXPECT_DOUBLE_EQ(values[1], 0.002);                   // time_s
  EXPECT_DOUBLE_EQ(values[4], 0.5);                     // position_m_1
  EXPECT_DOUBLE_EQ(values[9], -1.5);                    // command_N_0
  EXPECT_DOUBLE_EQ(values[11], -1.25);                  // rendered_force_N_0
}

TEST_F(TelemetryWriterTest, TakesDofFromTheFirstRecordWhenNotGiven) {
  const fs::path path = dir_ / "lazy.csv";
  {
    TelemetryWriter writer(path.string(), 16);
    ASSERT_TRUE(writer.Push(MakeRecord(0, 1)));
  }  // destructor stops and flushes
  const auto lines = ReadLines(path);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], TelemetryCsvHeader(1));
}

TEST_F(TelemetryWriterTest, FullRingCountsDropsAndWritesEverythingAccepted) {
  const fs::path path = dir_ / "drops.csv";
  TelemetryWriter writer(path.string(), 1, 1);
  constexpr std::uint64_t kOffered = 100'000;
  std::uint64_t refused = 0;
  for (std::uint64_t c = 0; c < kOffered; ++c) {
    if (!writer.Push(MakeRecord(c, 1))) ++refused;
  }
  writer.Stop();
  EXPECT_EQ(writer.dropped(), refused);
  EXPECT_EQ(writer.pushed() + writer.dropped(), kOffered);
  EXPECT_GT(writer.dropped(), 0u) << "a 1-record ring cannot keep up with a free-running producer";
  const auto lines = ReadLines(path);
  ASSERT_EQ(lines.size(), writer.pushed() + 1);
  EXPECT_EQ(writer.written(), writer.pushed());
  // Rows are the accepted records, in increasing cycle order.
  std::uint64_t last = 0;
  for (std::size_t i = 2; i < lines.size(); ++i) {
    const std::uint64_t cycle = std::stoull(lines[i].substr(0, lines[i].find(',')));
    EXPECT_GT(cycle, last);
    last = cycle;
  }
}

TEST_F(TelemetryWriterTest, PushDoesNotAllocate) {
  TelemetryWriter writer((dir_ / "alloc.csv").string(), 1024, 1);
  const TelemetryRecord r = MakeRecord(1, 1);
  std::uint64_t accepted = 0;
  {
    test::AllocationCounter counter;
    for (int i = 0; i < 500; ++i) accepted += writer.Push(r) ? 1 : 0;
    EXPECT_EQ(counter.count(), 0u);
  }
  EXPECT_EQ(accepted, 500u);
}

TEST_F(TelemetryWriterTest, UnwritablePathIsASetUpErrorNamingThePath) {
  const std::string bad = (dir_ / "no_such_dir" / "run.csv").string();
  try {
    TelemetryWriter writer(bad, 16, 1);
    FAIL() << "expected teleop::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
  }
  EXPECT_THROW(TelemetryWriter((dir_ / "x.csv").string(), 0, 1), Error);
  EXPECT_THROW(TelemetryWriter((dir_ / "y.csv").string(), 16, kMaxDof + 1), Error);
  EXPECT_THROW(TelemetryWriter((dir_ / "z.csv").string(), 16, 1, kMaxDof + 1), Error);
}

}  // namespace
}  // namespace teleop::runtime
