// The `dds:` section of a process config (docs/dds.md): defaults, every key, and each rejection with its location.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"
#include "test_utilities/base_config.hpp"

namespace teleop::config {
namespace {

using ::testing::HasSubstr;

const std::string kBase = test::BaseConfig("slave");

ProcessConfig WithDds(const std::string& dds) { return ParseProcessConfig(std::string(kBase) + dds, "rig.yaml"); }

std::string ErrorOf(const std::string& dds) {
  try {
    (void)WithDds(dds);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(DdsConfig, AbsentSectionLeavesTheBridgeOff) {
  const ProcessConfig c = ParseProcessConfig(kBase, "rig.yaml");
  EXPECT_FALSE(c.dds.enabled);
  EXPECT_EQ(c.dds.domain_id, 0);
  EXPECT_EQ(c.dds.pair, "teleop");
  EXPECT_DOUBLE_EQ(c.dds.state_rate_hz, 20.0);
}

TEST(DdsConfig, ReadsEveryKey) {
  const ProcessConfig c =
      WithDds("dds:\n  enabled: true\n  domain_id: 42\n  pair: rig_3\n  state_rate_hz: 50\n  ring_capacity: 1024\n");
  EXPECT_TRUE(c.dds.enabled);
  EXPECT_EQ(c.dds.domain_id, 42);
  EXPECT_EQ(c.dds.pair, "rig_3");
  EXPECT_DOUBLE_EQ(c.dds.state_rate_hz, 50.0);
  EXPECT_EQ(c.dds.ring_capacity, 1024);
}

TEST(DdsConfig, RejectsBadValuesAtTheirKey) {
  // Line 15 is the first line of the section, 16 the first key.
  EXPECT_THAT(ErrorOf("dds:\n  domain_id: 233\n"),
              HasSubstr("rig.yaml:17:14: key 'dds.domain_id': must be an integer in 0..232"));
  EXPECT_THAT(ErrorOf("dds:\n  domain_id: -1\n"), HasSubstr("key 'dds.domain_id'"));
  EXPECT_THAT(ErrorOf("dds:\n  pair: 3rig\n"), HasSubstr("key 'dds.pair': '3rig' is not a valid topic name part"));
  EXPECT_THAT(ErrorOf("dds:\n  pair: \"rig/a\"\n"), HasSubstr("not a valid topic name part"));
  EXPECT_THAT(ErrorOf("dds:\n  pair: a__b\n"), HasSubstr("not a valid topic name part"));
  EXPECT_THAT(ErrorOf("dds:\n  state_rate_hz: 2000\n"), HasSubstr("key 'dds.state_rate_hz': must be in 0.1..1000 Hz"));
  EXPECT_THAT(ErrorOf("dds:\n  state_rate_hz: .nan\n"), HasSubstr("key 'dds.state_rate_hz'"));
  EXPECT_THAT(ErrorOf("dds:\n  state_rate_hz: 0\n"), HasSubstr("key 'dds.state_rate_hz'"));
  EXPECT_THAT(ErrorOf("dds:\n  ring_capacity: 8\n"),
              HasSubstr("key 'dds.ring_capacity': must be an integer in 16..65536"));
  EXPECT_THAT(ErrorOf("dds:\n  enabled: maybe\n"), HasSubstr("key 'dds.enabled'"));
  EXPECT_THAT(ErrorOf("dds:\n  domain: 3\n"), HasSubstr("domain"));  // unknown key, with a hint
}

}  // namespace
}  // namespace teleop::config
