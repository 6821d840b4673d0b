// Every rig config under deploy/configs/ (found when the test runs, so a new rig's files are covered without editing
// this test) loads, passes the start-up stability check its process will run, and fits its CAN bus budget; and each
// master/slave pair in one folder agrees on what both ends must share (role, dof, rate, transport, addresses or CAN
// identifiers and bit rates).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "teleop/config/stability_check.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/can_bus_budget.hpp"

namespace teleop::config {
namespace {

namespace fs = std::filesystem;

std::vector<fs::path> RigConfigs() {
  std::vector<fs::path> out;
  for (const auto& entry : fs::recursive_directory_iterator(TELEOP_RIG_CONFIG_DIR)) {
    if (entry.is_regular_file() && entry.path().extension() == ".yaml") out.push_back(entry.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// "master-udp.yaml" -> "udp", "master.yaml" -> "": the key that pairs a master file with its slave file.
std::string PairKey(const fs::path& path, const std::string& role) {
  const std::string stem = path.stem().string();
  if (stem == role) return "";
  if (stem.rfind(role + "-", 0) == 0) return stem.substr(role.size() + 1);
  if (stem.rfind(role + "_", 0) == 0) return stem.substr(role.size() + 1);
  return "?" + stem;
}

TEST(RigConfigs, TheLoopbackRigIsThere) {
  const auto files = RigConfigs();
  for (const char* name : {"loopback/master-udp.yaml", "loopback/slave-udp.yaml", "loopback/master-can.yaml",
                           "loopback/slave-can.yaml", "master.yaml", "slave.yaml"}) {
    EXPECT_TRUE(fs::exists(fs::path(TELEOP_RIG_CONFIG_DIR) / name)) << name;
  }
  EXPECT_GE(files.size(), 6u);
}

// Each simulated rig has the four two-machine files: master and slave, over UDP and over CAN.
TEST(RigConfigs, EachRigHasUdpAndCanPairs) {
  for (const char* rig : {"loopback", "hybrid", "cobot"}) {
    for (const char* name : {"master-udp.yaml", "slave-udp.yaml", "master-can.yaml", "slave-can.yaml"}) {
      const fs::path path = fs::path(TELEOP_RIG_CONFIG_DIR) / rig / name;
      ASSERT_TRUE(fs::exists(path)) << path;
      const ProcessConfig config = LoadProcessConfig(path.string());
      const bool can = std::string(name).find("-can") != std::string::npos;
      EXPECT_EQ(config.link.transport, can ? "can" : "udp") << path;
    }
  }
}

TEST(RigConfigs, TheHybridRealRigAndHybridAsSlavePairsAreThere) {
  // Loaded, checked and paired by the tests below like every rig file; run as processes by
  // device.hybrid_process.* (tests/device/hybrid/hybrid_fieldbus_process_test.py).
  for (const char* name : {"hybrid/master-fieldbus.yaml", "hybrid/slave-fieldbus.yaml",
                           "hybrid/master-hybrid-as-slave.yaml", "hybrid/slave-hybrid-as-slave.yaml"}) {
    EXPECT_TRUE(fs::exists(fs::path(TELEOP_RIG_CONFIG_DIR) / name)) << name;
  }
  const ProcessConfig slave =
      LoadProcessConfig((fs::path(TELEOP_RIG_CONFIG_DIR) / "hybrid/slave-hybrid-as-slave.yaml").string());
  EXPECT_EQ(slave.role, Role::kSlave);
  EXPECT_EQ(slave.device.backend, "hybrid");
  const ProcessConfig master =
      LoadProcessConfig((fs::path(TELEOP_RIG_CONFIG_DIR) / "hybrid/master-fieldbus.yaml").string());
  EXPECT_EQ(master.device.backend, "hybrid");
}

TEST(RigConfigs, EveryConfigLoadsAndPassesItsStartUpCheck) {
  int loaded = 0;
  for (const auto& path : RigConfigs()) {
    SCOPED_TRACE(path.string());
    ProcessConfig config;
    try {
      config = LoadProcessConfig(path.string());
    } catch (const Error& e) {
      ADD_FAILURE() << e.what();
      continue;
    }
    ++loaded;
    // The sanitized pass loads every config (the readers under ASan + UBSan) but leaves the start-up analysis to the
    // release run, which checks every config: the same numeric code 30 times took 50 s there (an arm's sweep,
    // minutes), and StabilityCheck.* run it under the sanitizers.
#ifndef TELEOP_SANITIZED_BUILD
    if (config.stability.check) {
      const StabilityReport report = CheckProcessStability(config);
      EXPECT_TRUE(report.stable()) << DescribeFailure(config, report);
    }
#endif
    if (config.link.transport != "udp") {
      EXPECT_NO_THROW((void)transport::CheckCanBusBudget(config.link.can, config.loop.rate_hz));
    }
  }
  EXPECT_EQ(loaded, static_cast<int>(RigConfigs().size()));
}

TEST(RigConfigs, EachMasterHasAMatchingSlave) {
  // folder + pair key -> {master, slave}
  std::map<std::string, std::map<std::string, fs::path>> pairs;
  for (const auto& path : RigConfigs()) {
    const std::string stem = path.stem().string();
    for (const std::string role : {"master", "slave"}) {
      if (stem.rfind(role, 0) == 0) pairs[path.parent_path().string() + "|" + PairKey(path, role)][role] = path;
    }
  }
  ASSERT_FALSE(pairs.empty());
  for (const auto& [key, pair] : pairs) {
    SCOPED_TRACE(key);
    ASSERT_EQ(pair.count("master"), 1u) << "a slave config without its master";
    ASSERT_EQ(pair.count("slave"), 1u) << "a master config without its slave";
    ProcessConfig m;
    ProcessConfig s;
    try {
      m = LoadProcessConfig(pair.at("master").string());
      s = LoadProcessConfig(pair.at("slave").string());
    } catch (const Error& e) {
      ADD_FAILURE() << e.what();  // reported by the test above too
      continue;
    }
    EXPECT_EQ(m.role, Role::kMaster);
    EXPECT_EQ(s.role, Role::kSlave);
    EXPECT_EQ(m.dof, s.dof);
    EXPECT_DOUBLE_EQ(m.loop.rate_hz, s.loop.rate_hz);
    ASSERT_EQ(m.link.transport, s.link.transport);
    if (m.link.transport == "udp") {
      EXPECT_EQ(m.link.udp.peer_address, s.link.udp.bind_address);
      EXPECT_EQ(m.link.udp.peer_port, s.link.udp.bind_port);
      EXPECT_EQ(s.link.udp.peer_address, m.link.udp.bind_address);
      EXPECT_EQ(s.link.udp.peer_port, m.link.udp.bind_port);
    } else {
      const auto& a = m.link.can;
      const auto& b = s.link.can;
      EXPECT_EQ(a.fd, b.fd);
      EXPECT_EQ(a.bit_rate_switch, b.bit_rate_switch);
      EXPECT_DOUBLE_EQ(a.nominal_bitrate_bit_per_s, b.nominal_bitrate_bit_per_s);
      if (a.fd) {
        EXPECT_DOUBLE_EQ(a.data_bitrate_bit_per_s, b.data_bitrate_bit_per_s);
      }
      EXPECT_EQ(a.extended_id, b.extended_id);
      EXPECT_EQ(a.master_to_slave_base_id, b.master_to_slave_base_id);
      EXPECT_EQ(a.slave_to_master_base_id, b.slave_to_master_base_id);
      if (m.link.transport == "emulated-can") {
        EXPECT_EQ(a.emulated_bus_host, b.emulated_bus_host);
        EXPECT_EQ(a.emulated_bus_port, b.emulated_bus_port);
      }
    }
  }
}

}  // namespace
}  // namespace teleop::config
