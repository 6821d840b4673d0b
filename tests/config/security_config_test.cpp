// The `link.security` section (docs/configuration.md, docs/security.md): required, psk or insecure, the key path
// relative to the config, psk refused on CAN, ranges, and the messages a user sees.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"

namespace teleop::config {
namespace {

using ::testing::HasSubstr;

std::string Config(const std::string& link) {
  return "role: master\ndof: 2\nrate_hz: 1000\nlink:\n" + link +
         "law: {kp_N_per_m: 600, kd_Ns_per_m: 2}\n"
         "device: {backend: loopback, loopback: {mass_kg: 0.04, damping_Ns_per_m: 0.41}}\n";
}

const char* const kUdp = "  bind: \"127.0.0.1:47001\"\n  peer: \"127.0.0.1:47002\"\n";

std::string ErrorOf(const std::string& text, const std::string& name = "/etc/teleop/master.yaml") {
  try {
    (void)ParseProcessConfig(text, name);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(SecurityConfig, AConfigWithoutSecurityIsRefusedWithBothWaysOut) {
  const std::string error = ErrorOf(Config(kUdp));
  EXPECT_THAT(error, HasSubstr("/etc/teleop/master.yaml:5:3: key 'link'"));
  EXPECT_THAT(error, HasSubstr("teleop-keygen"));
  EXPECT_THAT(error, HasSubstr("mode: psk, key_file:"));
  EXPECT_THAT(error, HasSubstr("mode: insecure"));
}

TEST(SecurityConfig, PskReadsTheKeyPathRelativeToTheConfigAndTheBounds) {
  const ProcessConfig c = ParseProcessConfig(
      Config(std::string(kUdp) +
             "  security: {mode: psk, key_file: keys/teleop.key, max_speed_m_per_s: 1.5, max_force_N: 40, "
             "position_slack_m: 0.002, max_datagrams_per_s: 9000, datagram_burst: 100, max_handshakes_per_s: 5, "
             "handshake_burst: 2, handshake_retry_ms: 250}\n"),
      "/etc/teleop/master.yaml");
  EXPECT_EQ(c.link.security.mode, transport::LinkSecurityMode::kPsk);
  EXPECT_EQ(c.link.security.key_file, "/etc/teleop/keys/teleop.key");
  EXPECT_EQ(c.link.security.session.dof, 2);
  EXPECT_DOUBLE_EQ(c.link.security.session.max_speed_m_per_s, 1.5);
  EXPECT_DOUBLE_EQ(c.link.security.session.max_force_N, 40.0);
  EXPECT_DOUBLE_EQ(c.link.security.session.position_slack_m, 0.002);
  EXPECT_DOUBLE_EQ(c.link.security.session.max_datagrams_per_s, 9000.0);
  EXPECT_DOUBLE_EQ(c.link.security.session.datagram_burst, 100.0);
  EXPECT_DOUBLE_EQ(c.link.security.session.max_handshakes_per_s, 5.0);
  EXPECT_DOUBLE_EQ(c.link.security.session.handshake_burst, 2.0);
  EXPECT_DOUBLE_EQ(c.link.security.handshake_retry_ms, 250.0);
  const ProcessConfig absolute = ParseProcessConfig(
      Config(std::string(kUdp) + "  security: {mode: psk, key_file: /srv/k.key}\n"), "/etc/teleop/master.yaml");
  EXPECT_EQ(absolute.link.security.key_file, "/srv/k.key");
}

TEST(SecurityConfig, InsecureIsExplicitAndTakesNoPskKeys) {
  const ProcessConfig c =
      ParseProcessConfig(Config(std::string(kUdp) + "  security: {mode: insecure}\n"), "master.yaml");
  EXPECT_EQ(c.link.security.mode, transport::LinkSecurityMode::kInsecure);
  EXPECT_THAT(ErrorOf(Config(std::string(kUdp) + "  security: {mode: insecure, key_file: k}\n")),
              HasSubstr("key 'link.security.key_file': only for mode psk"));
  EXPECT_THAT(ErrorOf(Config(std::string(kUdp) + "  security: {}\n")), HasSubstr("mode"));
  EXPECT_THAT(ErrorOf(Config(std::string(kUdp) + "  security: {mode: plain}\n")),
              HasSubstr("must be psk or insecure, got 'plain'"));
  EXPECT_THAT(ErrorOf(Config(std::string(kUdp) + "  security: {mode: psk}\n")), HasSubstr("key_file"));
}

TEST(SecurityConfig, CanAcceptsOnlyInsecure) {
  const std::string can = "  transport: emulated-can\n";
  EXPECT_THAT(ErrorOf(Config(can + "  security: {mode: psk, key_file: teleop.key}\n")),
              HasSubstr("psk is not available on transport emulated-can"));
  const ProcessConfig c = ParseProcessConfig(Config(can + "  security: {mode: insecure}\n"), "master.yaml");
  EXPECT_EQ(c.link.security.mode, transport::LinkSecurityMode::kInsecure);
}

TEST(SecurityConfig, RangesAreChecked) {
  for (const char* bad : {"max_speed_m_per_s: 0", "max_force_N: -1", "position_slack_m: 2", "max_datagrams_per_s: 0",
                          "handshake_burst: 0", "handshake_retry_ms: 0.5", "max_handshakes_per_s: .nan"}) {
    const std::string text = Config(std::string(kUdp) + "  security: {mode: psk, key_file: teleop.key, " + bad + "}\n");
    EXPECT_THAT(ErrorOf(text), HasSubstr("key 'link.security.")) << bad;
  }
}

TEST(SecurityConfig, TheShippedConfigsSayHowTheyAreProtected) {
  // UDP: authenticated; CAN: explicitly insecure (docs/security.md, "CAN").
  for (const std::string name : {"master.yaml", "slave.yaml", "cobot/master-udp.yaml", "hybrid/slave-udp.yaml"}) {
    const ProcessConfig c = LoadProcessConfig(std::string(TELEOP_CONFIG_DIR) + "/" + name);
    EXPECT_EQ(c.link.security.mode, transport::LinkSecurityMode::kPsk) << name;
    // The key is beside the config file.
    const std::string dir = name.find('/') == std::string::npos ? "" : "/" + name.substr(0, name.find('/'));
    EXPECT_EQ(c.link.security.key_file, std::string(TELEOP_CONFIG_DIR) + dir + "/teleop.key") << name;
  }
  for (const char* name : {"master-can.yaml", "slave-can.yaml", "cobot/master-can.yaml", "hybrid/slave-can.yaml"}) {
    const ProcessConfig c = LoadProcessConfig(std::string(TELEOP_CONFIG_DIR) + "/" + name);
    EXPECT_EQ(c.link.security.mode, transport::LinkSecurityMode::kInsecure) << name;
  }
}

}  // namespace
}  // namespace teleop::config
