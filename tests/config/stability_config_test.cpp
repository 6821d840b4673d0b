// The `stability:` section of a process config: defaults, every key, and the errors for unknown keys and bad values
// (docs/configuration.md, `stability`).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <utility>

#include "teleop/config/yaml_config.hpp"
#include "teleop/device/loopback.hpp"
#include "teleop/error.hpp"
#include "test_utilities/base_config.hpp"

namespace teleop::config {
namespace {

using ::testing::HasSubstr;

const std::string kBase = test::BaseConfig("slave", 3);

std::string WithStability(const std::string& section) { return std::string(kBase) + "stability:\n" + section; }

/// 1-based "LINE:COL" of the first occurrence of `needle` in `text`.
std::string Where(const std::string& text, const std::string& needle) {
  const auto at = text.find(needle);
  EXPECT_NE(at, std::string::npos) << "test bug: '" << needle << "' not in the config";
  const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n');
  const auto line_start = text.rfind('\n', at);
  return std::to_string(line) + ":" + std::to_string(at - line_start);
}

/// Expects a teleop::Error "test.yaml:LINE:COL: key 'KEY': ...REASON..." located at `at_needle`.
void ExpectError(const std::string& text, const std::string& at_needle, const std::string& key,
                 const std::string& reason) {
  try {
    ParseProcessConfig(text, "test.yaml");
    ADD_FAILURE() << "expected teleop::Error for:\n" << text;
  } catch (const Error& e) {
    const std::string message = e.what();
    const std::string prefix = "test.yaml:" + Where(text, at_needle) + ": key '" + key + "': ";
    EXPECT_EQ(message.rfind(prefix, 0), 0u) << "message: " << message << "\nexpected prefix: " << prefix;
    EXPECT_THAT(message, HasSubstr(reason));
  }
}

TEST(StabilityConfig, AbsentSectionGivesTheDocumentedDefaults) {
  const ProcessConfig c = ParseProcessConfig(kBase, "test.yaml");
  const StabilityConfig& s = c.stability;
  EXPECT_TRUE(s.check);
  EXPECT_EQ(s.peer_delay_samples, 1);
  EXPECT_FALSE(s.unilateral);
  EXPECT_TRUE(s.human_bounds.empty());
  EXPECT_EQ(s.human_grid_steps, 4);
  EXPECT_FALSE(s.peer.mass_kg.has_value());
  EXPECT_FALSE(s.peer.damping_Ns_per_m.has_value());
  EXPECT_FALSE(s.peer.kp_N_per_m.has_value());
  EXPECT_FALSE(s.peer.kd_Ns_per_m.has_value());
  EXPECT_FALSE(s.peer.kv_Ns_per_m.has_value());
  EXPECT_FALSE(s.peer.kf.has_value());
  EXPECT_EQ(s.peer.fixture_stiffness_N_per_m, 0.0);
  EXPECT_FALSE(s.device.mass_kg.has_value());
  EXPECT_FALSE(s.device.damping_Ns_per_m.has_value());
  // An empty section is the same as none.
  const ProcessConfig empty = ParseProcessConfig(WithStability("  check: true\n"), "test.yaml");
  EXPECT_EQ(empty.stability.peer_delay_samples, 1);
  EXPECT_EQ(empty.stability.human_grid_steps, 4);
}

TEST(StabilityConfig, EveryKeyIsRead) {
  const ProcessConfig c = ParseProcessConfig(WithStability(R"(  check: false
  peer_delay_samples: 0
  unilateral: true
  human_bounds: "bounds.csv"
  human_grid_steps: 2
  peer:
    mass_kg: 0.05
    damping_Ns_per_m: 0.3
    kp_N_per_m: [500, 600, 700]
    kd_Ns_per_m: 3
    kv_Ns_per_m: [0, 0.5, 1]
    kf: -0.5
    fixture_stiffness_N_per_m: 1500
  device: {mass_kg: 0.2, damping_Ns_per_m: 1.5}
)"),
                                             "test.yaml");
  const StabilityConfig& s = c.stability;
  EXPECT_FALSE(s.check);
  EXPECT_EQ(s.peer_delay_samples, 0);
  EXPECT_TRUE(s.unilateral);
  EXPECT_EQ(s.human_bounds, "bounds.csv");
  EXPECT_EQ(s.human_grid_steps, 2);
  EXPECT_EQ(s.peer.mass_kg.value(), 0.05);
  EXPECT_EQ(s.peer.damping_Ns_per_m.value(), 0.3);
  ASSERT_TRUE(s.peer.kp_N_per_m.has_value());
  ASSERT_EQ(s.peer.kp_N_per_m->size(), 3);
  EXPECT_EQ((*s.peer.kp_N_per_m)[0], 500.0);
  EXPECT_EQ((*s.peer.kp_N_per_m)[2], 700.0);
  ASSERT_EQ(s.peer.kd_Ns_per_m->size(), 3);
  EXPECT_EQ((*s.peer.kd_Ns_per_m)[1], 3.0) << "a scalar applies to every DOF";
  EXPECT_EQ((*s.peer.kv_Ns_per_m)[2], 1.0);
  EXPECT_EQ((*s.peer.kf)[0], -0.5);
  EXPECT_EQ(s.peer.fixture_stiffness_N_per_m, 1500.0);
  EXPECT_EQ(s.device.mass_kg.value(), 0.2);
  EXPECT_EQ(s.device.damping_Ns_per_m.value(), 1.5);
}

TEST(StabilityConfig, UnknownKeysAreRejectedWhereTheyAre) {
  std::string text = WithStability("  chek: true\n");
  ExpectError(text, "chek", "stability.chek", "unknown key");
  text = WithStability("  peer:\n    stiffness_N_per_m: 2000\n");
  ExpectError(text, "stiffness_N_per_m: 2000", "stability.peer.stiffness_N_per_m", "unknown key");
  text = WithStability("  device: {mass_kg: 0.1, inertia: 2}\n");
  ExpectError(text, "inertia", "stability.device.inertia", "unknown key");
}

TEST(StabilityConfig, BadValuesAreRejectedWithTheirRange) {
  struct Case {
    const char* section;
    const char* at;
    const char* key;
    const char* reason;
  };
  const Case cases[] = {
      {"  peer_delay_samples: 2\n", "2\n", "stability.peer_delay_samples", "0..1"},
      {"  peer_delay_samples: -1\n", "-1", "stability.peer_delay_samples", "0..1"},
      {"  human_grid_steps: 0\n", "0\n", "stability.human_grid_steps", "1..8"},
      {"  human_grid_steps: 9\n", "9", "stability.human_grid_steps", "1..8"},
      {"  peer:\n    mass_kg: 0\n", "0\n", "stability.peer.mass_kg", "must be > 0 kg"},
      {"  peer:\n    mass_kg: .nan\n", ".nan", "stability.peer.mass_kg", "finite"},
      {"  peer:\n    damping_Ns_per_m: -0.1\n", "-0.1", "stability.peer.damping_Ns_per_m", ">= 0"},
      {"  peer:\n    kp_N_per_m: -600\n", "-600", "stability.peer.kp_N_per_m", ">= 0 N/m"},
      {"  peer:\n    kd_Ns_per_m: [2, 2]\n", "[2, 2]", "stability.peer.kd_Ns_per_m", "exactly 3"},
      {"  peer:\n    kv_Ns_per_m: .inf\n", ".inf", "stability.peer.kv_Ns_per_m", "finite"},
      {"  peer:\n    fixture_stiffness_N_per_m: -5\n", "-5", "stability.peer.fixture_stiffness_N_per_m", ">= 0 N/m"},
      {"  device:\n    mass_kg: -1\n", "-1", "stability.device.mass_kg", "must be > 0 kg"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.section);
    // The location is the offending value: find it after the section header.
    const std::string text = WithStability(c.section);
    try {
      ParseProcessConfig(text, "test.yaml");
      ADD_FAILURE() << "parsed";
    } catch (const Error& e) {
      const std::string message = e.what();
      const auto value_at = text.find(c.at, text.find("stability:"));
      const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(value_at), '\n');
      const auto column = value_at - text.rfind('\n', value_at);
      EXPECT_EQ(message.rfind(
                    "test.yaml:" + std::to_string(line) + ":" + std::to_string(column) + ": key '" + c.key + "': ", 0),
                0u)
          << message;
      EXPECT_THAT(message, HasSubstr(c.reason));
    }
  }
}

TEST(StabilityConfig, WrongTypesAreErrors) {
  for (const char* section : {"  check: maybe\n", "  unilateral: [true]\n", "  peer: 5\n", "  human_grid_steps: 2.5\n",
                              "  human_bounds: [a, b]\n"}) {
    SCOPED_TRACE(section);
    try {
      ParseProcessConfig(WithStability(section), "test.yaml");
      ADD_FAILURE() << "parsed";
    } catch (const Error& e) {
      EXPECT_THAT(std::string(e.what()), HasSubstr("key 'stability."));
    }
  }
}

/// Each shipped pair of configs describes the other side in its stability section as the other file really is.
void ExpectPeersDescribeEachOther(const std::string& master_path, const std::string& slave_path) {
  const ProcessConfig master = LoadProcessConfig(master_path);
  const ProcessConfig slave = LoadProcessConfig(slave_path);
  for (const auto& [self, other] : {std::pair{&master, &slave}, std::pair{&slave, &master}}) {
    SCOPED_TRACE(self->source_path);
    const StabilityConfig::Peer& peer = self->stability.peer;
    ASSERT_TRUE(peer.mass_kg && peer.damping_Ns_per_m && peer.kp_N_per_m && peer.kd_Ns_per_m && peer.kv_Ns_per_m);
    EXPECT_EQ(*peer.mass_kg, other->device.Section<device::LoopbackPlantConfig>().mass_kg);
    EXPECT_EQ(*peer.damping_Ns_per_m, other->device.Section<device::LoopbackPlantConfig>().damping_Ns_per_m);
    EXPECT_EQ(*peer.kp_N_per_m, other->law.kp_N_per_m);
    EXPECT_EQ(*peer.kd_Ns_per_m, other->law.kd_Ns_per_m);
    EXPECT_EQ(*peer.kv_Ns_per_m, other->law.kv_Ns_per_m);
    const double other_fixture = other->law.fixture.plane_count > 0 ? other->law.fixture.stiffness_N_per_m : 0.0;
    EXPECT_EQ(peer.fixture_stiffness_N_per_m, other_fixture);
    EXPECT_TRUE(self->stability.check);
  }
}

TEST(StabilityConfig, ShippedConfigsDescribeTheirPeerAsItIs) {
  ExpectPeersDescribeEachOther(std::string(TELEOP_SOURCE_DIR) + "/deploy/configs/master.yaml",
                               std::string(TELEOP_SOURCE_DIR) + "/deploy/configs/slave.yaml");
  ExpectPeersDescribeEachOther(std::string(TELEOP_SOURCE_DIR) + "/tests/qemu/configs/master_can.yaml",
                               std::string(TELEOP_SOURCE_DIR) + "/tests/qemu/configs/slave_can.yaml");
}

}  // namespace
}  // namespace teleop::config
