// The `engagement:` and `safety:` sections (common/src/config/safety_section.cpp): defaults per role, every key
// read, range errors located at the value, reactions per role, and every key documented in docs/configuration.md.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "teleop/config/yaml_config.hpp"
#include "test_utilities/config_text.hpp"

namespace teleop::config {
namespace {

using config::Reaction;
using test::ExpectError;

std::string Base(const char* role) {
  return std::string("role: ") + role + R"(
dof: 1
rate_hz: 1000
link: {security: {mode: insecure}, bind: "127.0.0.1:47001", peer: "127.0.0.1:47002"}
law: {kp_N_per_m: 600, kd_Ns_per_m: 0}
device: {backend: loopback, loopback: {mass_kg: 0.04, damping_Ns_per_m: 0.4}}
)";
}

constexpr const char* kEngagementKeys[] = {"align_speed_m_per_s", "align_min_time_ms", "align_tolerance_m",
                                           "max_force_rate_N_per_s", "max_rtt_ms"};
constexpr const char* kSafetyKeys[] = {
    "reaction",           "hold_max_force_N",       "decelerate_m_per_s2", "fade_time_ms",
    "damping_Ns_per_m",   "fault_record_cycles",    "fault_record_dir",    "max_fault_records",
    "max_abs_position_m", "max_abs_force_sensor_N", "max_speed_m_per_s",   "encoder_slack_m"};

TEST(SafetyConfig, DefaultsPerRole) {
  const ProcessConfig m = ParseProcessConfig(Base("master"), "test.yaml");
  const ProcessConfig s = ParseProcessConfig(Base("slave"), "test.yaml");
  EXPECT_EQ(m.safety.reaction, Reaction::kFade);
  EXPECT_EQ(s.safety.reaction, Reaction::kHold);
  EXPECT_EQ(s.safety.fault_record_cycles, 500);
  EXPECT_EQ(s.engagement.align_speed_m_per_s, 0.05);
  EXPECT_EQ(s.engagement.max_rtt_ms, 100.0);
}

TEST(SafetyConfig, EveryKeyIsRead) {
  const std::string text = Base("slave") + R"(engagement:
  align_speed_m_per_s: 0.02
  align_min_time_ms: 80
  align_tolerance_m: 0.0002
  max_force_rate_N_per_s: 50
  max_rtt_ms: 0
safety:
  reaction: decelerate
  hold_max_force_N: 3
  decelerate_m_per_s2: 2
  fade_time_ms: 300
  damping_Ns_per_m: 4
  fault_record_cycles: 1000
  fault_record_dir: /tmp/faults
  max_fault_records: 5
  max_abs_position_m: 0.3
  max_abs_force_sensor_N: 40
  max_speed_m_per_s: 2
  encoder_slack_m: 0.0005
)";
  const ProcessConfig c = ParseProcessConfig(text, "test.yaml");
  EXPECT_EQ(c.engagement.align_speed_m_per_s, 0.02);
  EXPECT_EQ(c.engagement.align_min_time_ms, 80.0);
  EXPECT_EQ(c.engagement.align_tolerance_m, 0.0002);
  EXPECT_EQ(c.engagement.max_force_rate_N_per_s, 50.0);
  EXPECT_EQ(c.engagement.max_rtt_ms, 0.0);
  EXPECT_EQ(c.safety.reaction, Reaction::kDecelerate);
  EXPECT_EQ(c.safety.hold_max_force_N, 3.0);
  EXPECT_EQ(c.safety.decelerate_m_per_s2, 2.0);
  EXPECT_EQ(c.safety.fade_time_ms, 300.0);
  EXPECT_EQ(c.safety.damping_Ns_per_m, 4.0);
  EXPECT_EQ(c.safety.fault_record_cycles, 1000);
  EXPECT_EQ(c.safety.fault_record_dir, "/tmp/faults");
  EXPECT_EQ(c.safety.max_fault_records, 5);
  EXPECT_EQ(c.safety.max_abs_position_m, 0.3);
  EXPECT_EQ(c.safety.max_abs_force_sensor_N, 40.0);
  EXPECT_EQ(c.safety.max_speed_m_per_s, 2.0);
  EXPECT_EQ(c.safety.encoder_slack_m, 0.0005);
}

TEST(SafetyConfig, ReactionsPerRoleAndRangesAreCheckedAtTheValue) {
  EXPECT_EQ(ParseProcessConfig(Base("master") + "safety: {reaction: damping}\n", "t").safety.reaction,
            Reaction::kDamping);
  EXPECT_EQ(ParseProcessConfig(Base("slave") + "safety: {reaction: brake}\n", "t").safety.reaction, Reaction::kBrake);
  EXPECT_EQ(ParseProcessConfig(Base("slave") + "safety: {reaction: zero_force}\n", "t").safety.reaction,
            Reaction::kZeroForce);
  std::string t = Base("master") + "safety: {reaction: hold}\n";
  ExpectError(t, "hold", "safety.reaction", "the master's reaction must be 'fade', 'damping'");
  t = Base("slave") + "safety: {reaction: fade}\n";
  ExpectError(t, "fade", "safety.reaction", "the slave's reaction must be 'hold', 'decelerate'");
  t = Base("slave") + "engagement: {align_speed_m_per_s: 0.0}\n";
  ExpectError(t, "0.0}", "engagement.align_speed_m_per_s", "must be in");
  t = Base("slave") + "engagement: {max_rtt_ms: -1}\n";
  ExpectError(t, "-1", "engagement.max_rtt_ms", "must be in 0..");
  t = Base("slave") + "safety: {fault_record_cycles: -5}\n";
  ExpectError(t, "-5", "safety.fault_record_cycles", "1..1000000");
  t = Base("slave") + "safety: {encoder_slack_m: .nan}\n";
  ExpectError(t, ".nan", "safety.encoder_slack_m", "");
  t = Base("slave") + "safety: {hold_force_N: 3}\n";
  ExpectError(t, "hold_force_N", "safety.hold_force_N", "did you mean 'hold_max_force_N'");
}

/// The first cells of the table rows under "## `<section>`" up to the next "## ".
std::string DocumentedCells(const std::string& section) {
  std::ifstream in(std::string(TELEOP_SOURCE_DIR) + "/docs/configuration.md");
  std::string cells;
  bool inside = false;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("## ", 0) == 0) inside = line == "## `" + section + "`";
    if (inside && line.rfind("| `", 0) == 0) cells += line.substr(0, line.find('|', 1)) + "\n";
  }
  return cells;
}

TEST(SafetyConfig, EveryKeyIsDocumented) {
  const std::string engagement = DocumentedCells("engagement");
  const std::string safety = DocumentedCells("safety");
  ASSERT_FALSE(engagement.empty()) << "docs/configuration.md has no '## `engagement`' table";
  ASSERT_FALSE(safety.empty()) << "docs/configuration.md has no '## `safety`' table";
  for (const char* key : kEngagementKeys) EXPECT_THAT(engagement, ::testing::HasSubstr(std::string("`") + key + "`"));
  for (const char* key : kSafetyKeys) EXPECT_THAT(safety, ::testing::HasSubstr(std::string("`") + key + "`"));
  // And the reader accepts exactly these: each one alone parses.
  for (const char* key : kEngagementKeys) {
    const std::string value = std::string(key) == "max_rtt_ms" ? "0" : "0.01";
    EXPECT_NO_THROW(ParseProcessConfig(Base("slave") + "engagement: {" + key + ": " + value + "}\n", "t")) << key;
  }
}

}  // namespace
}  // namespace teleop::config
