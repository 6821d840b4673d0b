#include "teleop/config/yaml_config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "teleop/device/loopback.hpp"
#include "teleop/error.hpp"
#include "test_utilities/base_config.hpp"
#include "test_utilities/config_text.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::config {
namespace {

using ::testing::HasSubstr;

// A small valid master config. Tests replace one line at a time, so line numbers stay put.
const std::string kBase = [] {
  std::string text = test::BaseConfig("master");
  const std::string peer = "  peer: \"127.0.0.1:47002\"\n";
  text.replace(text.find(peer), peer.size(), peer + "  timeout_ms: 50\n");
  return text + R"(    operator:
      script:
        - {type: ramp, start_s: 0.5, duration_s: 1.5, from_N: 0, to_N: 3}
)";
}();

using test::ErrorOf;
using test::ExpectError;
using test::Replace;

TEST(YamlConfig, BaseConfigParsesWithDefaults) {
  const ProcessConfig c = ParseProcessConfig(kBase, "test.yaml");
  EXPECT_EQ(c.role, Role::kMaster);
  EXPECT_EQ(c.dof, 1);
  EXPECT_EQ(c.source_path, "test.yaml");
  EXPECT_EQ(c.loop.rate_hz, 1000.0);
  EXPECT_EQ(c.loop.fifo_priority, 0);
  EXPECT_EQ(c.loop.cpu, -1);
  EXPECT_FALSE(c.loop.lock_memory);
  EXPECT_EQ(c.loop.duration_s, 0.0);
  EXPECT_EQ(c.link.transport, "udp");
  EXPECT_EQ(c.link.udp.expected_peer, proto::SenderRole::kSlave);
  EXPECT_EQ(c.law.kv_Ns_per_m.size(), 1);
  EXPECT_EQ(c.law.kv_Ns_per_m[0], 0.0);
  EXPECT_EQ(c.law.kf[0], 0.0);
  EXPECT_EQ(c.law.max_force_N, 0.0);
  EXPECT_EQ(c.law.fixture.plane_count, 0);
  EXPECT_EQ(c.law.fixture.stiffness_N_per_m, 0.0);
  EXPECT_TRUE(c.telemetry.csv_path.empty());
  EXPECT_EQ(c.telemetry.decimation, 1);
}

TEST(YamlConfig, GainsTakeAScalarForEveryDofOrAListOfDofNumbers) {
  std::string text = Replace(kBase, "dof: 1", "dof: 3");
  text = Replace(text, "kp_N_per_m: 600", "kp_N_per_m: [100, 200, 300.5]");
  const ProcessConfig c = ParseProcessConfig(text, "test.yaml");
  ASSERT_EQ(c.law.kp_N_per_m.size(), 3);
  EXPECT_EQ(c.law.kp_N_per_m[0], 100.0);
  EXPECT_EQ(c.law.kp_N_per_m[1], 200.0);
  EXPECT_EQ(c.law.kp_N_per_m[2], 300.5);
  ASSERT_EQ(c.law.kd_Ns_per_m.size(), 3);
  EXPECT_EQ(c.law.kd_Ns_per_m[2], 2.0) << "scalar applied to every DOF";
  EXPECT_EQ(c.device.dof, 3);
  EXPECT_EQ(c.device.Section<device::LoopbackPlantConfig>().dof, 3);
  EXPECT_EQ(c.law.fixture.dof, 3);
}

TEST(YamlConfig, HalfSpaceShorthandBecomesOnePlane) {
  const std::string text = std::string(kBase) +
                           "fixture:\n  stiffness_N_per_m: 1500\n"
                           "  half_space: {axis: 0, offset_m: 0.02, direction: -1}\n";
  const ProcessConfig c = ParseProcessConfig(text, "test.yaml");
  EXPECT_EQ(c.law.fixture.stiffness_N_per_m, 1500.0);
  ASSERT_EQ(c.law.fixture.plane_count, 1);
  // Forbid x < 0.02: n = -1, n·x > -0.02.
  EXPECT_EQ(c.law.fixture.planes[0].normal[0], -1.0);
  EXPECT_DOUBLE_EQ(c.law.fixture.planes[0].offset_m, -0.02);
}

TEST(YamlConfig, ExplicitPlanes) {
  std::string text = Replace(kBase, "dof: 1", "dof: 2");
  text +=
      "fixture:\n  stiffness_N_per_m: 800\n  planes:\n    - {normal: [1, 0], offset_m: 0.01}\n"
      "    - {normal: [0, -2], offset_m: 0.03}\n";
  const ProcessConfig c = ParseProcessConfig(text, "test.yaml");
  ASSERT_EQ(c.law.fixture.plane_count, 2);
  EXPECT_EQ(c.law.fixture.planes[1].normal[1], -2.0) << "normalised by the fixture, not here";
  EXPECT_EQ(c.law.fixture.planes[1].offset_m, 0.03);
}

TEST(YamlConfig, FixturePlaneMoveRates) {
  const std::string base =
      std::string(kBase) + "fixture:\n  stiffness_N_per_m: 1500\n  half_space: {axis: 0, offset_m: 0}\n";
  const ProcessConfig defaults = ParseProcessConfig(base, "test.yaml");
  EXPECT_EQ(defaults.law.fixture.max_offset_rate_m_per_s, 0.01) << "docs/configuration.md's default";
  EXPECT_EQ(defaults.law.fixture.max_normal_rate_rad_per_s, 0.1);
  const ProcessConfig c =
      ParseProcessConfig(base + "  max_offset_rate_m_per_s: 0.02\n  max_normal_rate_rad_per_s: 0.5\n", "test.yaml");
  EXPECT_EQ(c.law.fixture.max_offset_rate_m_per_s, 0.02);
  EXPECT_EQ(c.law.fixture.max_normal_rate_rad_per_s, 0.5);
  ExpectError(base + "  max_offset_rate_m_per_s: 0e0\n", "0e0", "fixture.max_offset_rate_m_per_s", "> 0");
  ExpectError(base + "  max_normal_rate_rad_per_s: -1.5\n", "-1.5", "fixture.max_normal_rate_rad_per_s", "> 0");
}

TEST(YamlConfig, ExampleMasterConfigParses) {
  const ProcessConfig c = LoadProcessConfig(TELEOP_CONFIG_DIR "/master.yaml");
  EXPECT_EQ(c.role, Role::kMaster);
  EXPECT_EQ(c.dof, 1);
  EXPECT_EQ(c.loop.rate_hz, 1000.0);
  EXPECT_EQ(c.link.udp.bind_address, "127.0.0.1");
  EXPECT_EQ(c.link.udp.bind_port, 47001);
  EXPECT_EQ(c.link.udp.peer_address, "127.0.0.1");
  EXPECT_EQ(c.link.udp.peer_port, 47002);
  EXPECT_EQ(c.link.udp.expected_peer, proto::SenderRole::kSlave);
  EXPECT_EQ(c.link.timeout_ms, 50.0);
  EXPECT_EQ(c.law.role, Role::kMaster);
  EXPECT_EQ(c.law.kp_N_per_m[0], 600.0);
  EXPECT_EQ(c.law.kd_Ns_per_m[0], 2.0);
  EXPECT_EQ(c.law.max_force_N, 10.0);
  EXPECT_EQ(c.law.velocity_filter_hz, 200.0);
  EXPECT_EQ(c.law.fixture.plane_count, 0) << "master fixture off";
  EXPECT_EQ(c.device.backend, "loopback");
  const auto& plant = c.device.Section<device::LoopbackPlantConfig>();
  EXPECT_EQ(plant.mass_kg, 0.040);
  EXPECT_EQ(plant.damping_Ns_per_m, 0.41);
  ASSERT_TRUE(plant.human.enabled);
  EXPECT_EQ(plant.human.mass_kg, 0.01);
  EXPECT_EQ(plant.human.damping_Ns_per_m, 2.0);
  EXPECT_EQ(plant.human.stiffness_N_per_m, 200.0);
  ASSERT_EQ(plant.human.segment_count, 4);
  using Kind = device::OperatorSegment::Kind;
  const auto& s = plant.human.segments;
  EXPECT_EQ(s[0].kind, Kind::kRamp);
  EXPECT_EQ(s[0].start_s, 0.5);
  EXPECT_EQ(s[0].duration_s, 1.5);
  EXPECT_EQ(s[0].from_N, 0.0);
  EXPECT_EQ(s[0].to_N, 3.0);
  EXPECT_EQ(s[1].kind, Kind::kHold);
  EXPECT_EQ(s[1].start_s + s[1].duration_s, 3.0);
  EXPECT_EQ(s[2].kind, Kind::kRamp);
  EXPECT_EQ(s[2].start_s + s[2].duration_s, 4.0);
  EXPECT_EQ(s[2].to_N, -1.0);
  EXPECT_EQ(s[3].kind, Kind::kHold);
  EXPECT_EQ(s[3].start_s, 4.0);
  EXPECT_EQ(s[3].duration_s, 0.0) << "0 = until the end";
  EXPECT_EQ(plant.environment.kind, device::SimulatedEnvironmentConfig::Kind::kFreeSpace);
}

TEST(YamlConfig, ExampleSlaveConfigParses) {
  const ProcessConfig c = LoadProcessConfig(TELEOP_CONFIG_DIR "/slave.yaml");
  EXPECT_EQ(c.role, Role::kSlave);
  EXPECT_EQ(c.link.udp.bind_port, 47002);
  EXPECT_EQ(c.link.udp.peer_port, 47001);
  EXPECT_EQ(c.link.udp.expected_peer, proto::SenderRole::kMaster);
  EXPECT_EQ(c.law.role, Role::kSlave);
  EXPECT_EQ(c.law.kp_N_per_m[0], 600.0);
  EXPECT_EQ(c.law.kd_Ns_per_m[0], 2.0);
  EXPECT_EQ(c.law.fixture.stiffness_N_per_m, 2000.0);
  ASSERT_EQ(c.law.fixture.plane_count, 1);
  EXPECT_EQ(c.law.fixture.planes[0].normal[0], 1.0);
  EXPECT_EQ(c.law.fixture.planes[0].offset_m, 0.01);
  EXPECT_FALSE(c.device.Section<device::LoopbackPlantConfig>().human.enabled);
  EXPECT_EQ(c.device.Section<device::LoopbackPlantConfig>().mass_kg, 0.036);
  EXPECT_EQ(c.device.Section<device::LoopbackPlantConfig>().environment.kind,
            device::SimulatedEnvironmentConfig::Kind::kFreeSpace);
  EXPECT_EQ(c.law.max_force_N, 10.0);
}

// ---- one test per error class: file, line, column and key path are in the message ----------------------------

TEST(YamlConfigErrors, UnknownTopLevelKeySuggestsTheClosest) {
  const std::string text = Replace(kBase, "rate_hz: 1000", "rate_hx: 1000");
  ExpectError(text, "rate_hx", "rate_hx", "unknown key (did you mean 'rate_hz'?)");
}

TEST(YamlConfigErrors, UnknownKeyInASection) {
  const std::string text = Replace(kBase, "  kd_Ns_per_m: 2", "  kd_Ns_per_m: 2\n  ki_N_per_m_s: 3");
  ExpectError(text, "ki_N_per_m_s", "law.ki_N_per_m_s", "allowed here: kp_N_per_m, kd_Ns_per_m");
}

TEST(YamlConfigErrors, UnknownKeyDeepInAList) {
  const std::string text = Replace(kBase, "to_N: 3}", "to_N: 3, slope_N_per_s: 2}");
  ExpectError(text, "slope_N_per_s", "device.loopback.operator.script[0].slope_N_per_s", "unknown key");
}

TEST(YamlConfigErrors, KeyOfAnotherSegmentTypeIsUnknown) {
  const std::string text = Replace(kBase, "{type: ramp,", "{type: hold, amplitude_N: 1, ");
  ExpectError(text, "amplitude_N", "device.loopback.operator.script[0].amplitude_N", "unknown key");
}

TEST(YamlConfigErrors, UnknownSegmentKeyListsOnlyThatTypesKeys) {
  const std::string text = Replace(kBase, "to_N: 3}", "to_N: 3, amplitude_N: 2}");
  ExpectError(text, "amplitude_N", "device.loopback.operator.script[0].amplitude_N",
              "allowed here: type, axis, start_s, duration_s, from_N, to_N");
  EXPECT_THAT(ErrorOf(text), ::testing::Not(HasSubstr("frequency_hz")));
}

TEST(YamlConfigErrors, MissingRequiredKey) {
  const std::string text = Replace(kBase, "  kd_Ns_per_m: 2\n", "");
  // Located at the 'law' mapping (its first key).
  ExpectError(text, "kp_N_per_m", "law.kd_Ns_per_m", "missing required key in the 'law' section");
}

TEST(YamlConfigErrors, MissingRequiredTopLevelKey) {
  const std::string text = Replace(kBase, "role: master\n", "");
  ExpectError(text, "dof", "role", "missing required key");
}

TEST(YamlConfigErrors, WrongTypeNumber) {
  const std::string text = Replace(kBase, "kp_N_per_m: 600", "kp_N_per_m: stiff");
  ExpectError(text, "stiff", "law.kp_N_per_m", "expected a number, got 'stiff'");
}

TEST(YamlConfigErrors, WrongTypeSection) {
  const std::string text = Replace(kBase, "rate_hz: 1000", "rate_hz: 1000\nrealtime: 5");
  ExpectError(text, "5", "realtime", "expected a mapping");
}

TEST(YamlConfigErrors, WrongTypeIntegerAndBool) {
  ExpectError(Replace(kBase, "dof: 1", "dof: 1.5"), "1.5", "dof", "expected an integer");
  ExpectError(Replace(kBase, "rate_hz: 1000", "rate_hz: 1000\nrealtime: {lock_memory: sometimes}"), "sometimes",
              "realtime.lock_memory", "expected true or false");
}

TEST(YamlConfigErrors, OutOfRange) {
  ExpectError(Replace(kBase, "rate_hz: 1000", "rate_hz: 9000"), "9000", "rate_hz", "250..8000 Hz");
  ExpectError(Replace(kBase, "dof: 1", "dof: 13"), "13", "dof", "1..12");
  ExpectError(Replace(kBase, "kp_N_per_m: 600", "kp_N_per_m: -600"), "-600", "law.kp_N_per_m", ">= 0");
  ExpectError(Replace(kBase, "kp_N_per_m: 600", "kp_N_per_m: .nan"), ".nan", "law.kp_N_per_m", "finite");
  ExpectError(Replace(kBase, "mass_kg: 0.04", "mass_kg: 0"), "0\n    damping", "device.loopback.mass_kg", "> 0 kg");
  ExpectError(Replace(kBase, "timeout_ms: 50", "timeout_ms: 0"), "0\nlaw:", "link.timeout_ms", "> 0 ms");
  ExpectError(Replace(kBase, "timeout_ms: 50", "timeout_ms: 0.5"), "0.5", "link.timeout_ms",
              "at least one loop period");
  ExpectError(Replace(kBase, "kd_Ns_per_m: 2", "kd_Ns_per_m: 2\n  velocity_filter_hz: 900"), "900",
              "law.velocity_filter_hz", "half of rate_hz");
  ExpectError(Replace(kBase, "rate_hz: 1000", "rate_hz: 1000\nrealtime: {fifo_priority: 120}"), "120",
              "realtime.fifo_priority", "0..99");
}

TEST(YamlConfig, UdpRunsAt8kHz) {
  EXPECT_EQ(ParseProcessConfig(Replace(kBase, "rate_hz: 1000", "rate_hz: 8000"), "test.yaml").loop.rate_hz, 8000.0);
}

TEST(YamlConfig, SyncModeAndItsTimeoutMargin) {
  const ProcessConfig free = ParseProcessConfig(kBase, "test.yaml");
  EXPECT_EQ(free.loop.sync, runtime::CycleSync::kFree) << "free-running is the default";
  EXPECT_EQ(free.loop.trigger_timeout_margin_ns, 0) << "0 = a quarter period";
  const ProcessConfig t = ParseProcessConfig(
      Replace(kBase, "rate_hz: 1000", "rate_hz: 1000\nsync: {mode: triggered, timeout_margin_us: 300}"), "test.yaml");
  EXPECT_EQ(t.loop.sync, runtime::CycleSync::kTriggered);
  EXPECT_EQ(t.loop.trigger_timeout_margin_ns, 300'000);
  const std::string sync = "rate_hz: 1000\nsync: {mode: ";
  ExpectError(Replace(kBase, "rate_hz: 1000", sync + "pll}"), "pll", "sync.mode", "'free' or 'triggered'");
  EXPECT_EQ(ParseProcessConfig(Replace(kBase, "rate_hz: 1000", sync + "triggered, spin_us: 50}"), "test.yaml")
                .loop.trigger_spin_ns,
            50'000);
  ExpectError(Replace(kBase, "rate_hz: 1000", sync + "triggered, spin_us: 2000}"), "2000", "sync.spin_us",
              "at most one period");
  ExpectError(Replace(kBase, "rate_hz: 1000", sync + "triggered, timeout_margin_us: 1500}"), "1500",
              "sync.timeout_margin_us", "at most one period");
  ExpectError(Replace(kBase, "rate_hz: 1000", sync + "triggered, timeout_margin_us: 0}"), "0}",
              "sync.timeout_margin_us", "1..1000");
}

TEST(YamlConfig, BusyPollIsAUdpLinkKey) {
  EXPECT_EQ(ParseProcessConfig(kBase, "test.yaml").link.udp.busy_poll_us, 0) << "off by default";
  EXPECT_EQ(ParseProcessConfig(Replace(kBase, "  timeout_ms: 50", "  timeout_ms: 50\n  busy_poll_us: 50"), "test.yaml")
                .link.udp.busy_poll_us,
            50);
  ExpectError(Replace(kBase, "  timeout_ms: 50", "  timeout_ms: 50\n  busy_poll_us: -1"), "-1", "link.busy_poll_us",
              "0..100000");
}

TEST(YamlConfig, RealtimeHoldsCpuDmaLatency) {
  EXPECT_EQ(ParseProcessConfig(kBase, "test.yaml").loop.cpu_dma_latency_us, -1) << "left alone by default";
  const ProcessConfig c = ParseProcessConfig(
      Replace(kBase, "rate_hz: 1000", "rate_hz: 1000\nrealtime: {cpu_dma_latency_us: 0}"), "test.yaml");
  EXPECT_EQ(c.loop.cpu_dma_latency_us, 0);
  ExpectError(Replace(kBase, "rate_hz: 1000", "rate_hz: 1000\nrealtime: {cpu_dma_latency_us: -2}"), "-2",
              "realtime.cpu_dma_latency_us", "-1..1000000");
}

TEST(YamlConfig, StabilityPeerDelayFraction) {
  EXPECT_FALSE(ParseProcessConfig(kBase, "test.yaml").stability.peer_delay_fraction.has_value());
  const ProcessConfig c = ParseProcessConfig(
      Replace(kBase, "rate_hz: 1000", "rate_hz: 1000\nstability: {peer_delay_fraction: 0.05}"), "test.yaml");
  EXPECT_EQ(c.stability.peer_delay_fraction, 0.05);
  ExpectError(Replace(kBase, "rate_hz: 1000", "rate_hz: 1000\nstability: {peer_delay_fraction: 1.5}"), "1.5",
              "stability.peer_delay_fraction", "0..1");
}

TEST(YamlConfigErrors, BadListLength) {
  const std::string text = Replace(kBase, "kp_N_per_m: 600", "kp_N_per_m: [600, 700]");
  ExpectError(text, "[600", "law.kp_N_per_m", "exactly 1 numbers (dof), got a list of 2");
}

TEST(YamlConfigErrors, BadListElementNamesItsIndex) {
  std::string text = Replace(kBase, "dof: 1", "dof: 3");
  text = Replace(text, "kp_N_per_m: 600", "kp_N_per_m: [600, -1, 600]");
  ExpectError(text, "-1", "law.kp_N_per_m[1]", ">= 0");
}

TEST(YamlConfigErrors, BadAddress) {
  ExpectError(Replace(kBase, "\"127.0.0.1:47001\"", "\"localhost:47001\""), "\"localhost", "link.bind",
              "'localhost' is not a numeric IPv4 address");
  ExpectError(Replace(kBase, "\"127.0.0.1:47002\"", "\"127.0.0.1\""), "\"127.0.0.1\"", "link.peer", "");
  ExpectError(Replace(kBase, "\"127.0.0.1:47002\"", "\"127.0.0.1:70000\""), "\"127.0.0.1:70000", "link.peer",
              "outside 1..65535");
  ExpectError(Replace(kBase, "\"127.0.0.1:47002\"", "\"127.0.0.1:47001\""), "\"127.0.0.1:47001\"\n  timeout",
              "link.peer", "same endpoint");
}

TEST(YamlConfigErrors, Ipv6AddressesAreAccepted) {
  std::string text = Replace(kBase, "\"127.0.0.1:47001\"", "\"[::1]:47001\"");
  text = Replace(text, "\"127.0.0.1:47002\"", "\"[::1]:47002\"");
  const ProcessConfig c = ParseProcessConfig(text, "test.yaml");
  EXPECT_EQ(c.link.udp.bind_address, "::1");
  EXPECT_EQ(c.link.udp.peer_port, 47002);
}

TEST(YamlConfigErrors, DuplicateKey) {
  const std::string text = Replace(kBase, "  kd_Ns_per_m: 2", "  kd_Ns_per_m: 2\n  kp_N_per_m: 700");
  ExpectError(text, "kp_N_per_m: 700", "law.kp_N_per_m", "duplicate key");
}

TEST(YamlConfigErrors, FixtureNeedsExactlyOneShape) {
  const std::string both = std::string(kBase) +
                           "fixture:\n  stiffness_N_per_m: 1\n  planes: [{normal: [1], offset_m: 0}]\n"
                           "  half_space: {axis: 0, offset_m: 0}\n";
  ExpectError(both, "{axis", "fixture.half_space", "not both");
  const std::string none = std::string(kBase) + "fixture:\n  stiffness_N_per_m: 1\n";
  ExpectError(none, "stiffness_N_per_m: 1", "fixture", "needs either");
  const std::string axis =
      std::string(kBase) + "fixture:\n  stiffness_N_per_m: 1\n  half_space: {axis: 1, offset_m: 0}\n";
  ExpectError(axis, "1, offset", "fixture.half_space.axis", "0..0");
}

TEST(YamlConfigErrors, UnsupportedBackendAndTransport) {
  ExpectError(Replace(kBase, "backend: loopback", "backend: warp_drive"), "warp_drive", "device.backend",
              "unknown backend 'warp_drive'");
  ExpectError(Replace(kBase, "  bind:", "  transport: pigeon\n  bind:"), "pigeon", "link.transport",
              "unsupported transport");
}

TEST(YamlConfigErrors, SyntaxErrorIsLocated) {
  const std::string text = Replace(kBase, "  kd_Ns_per_m: 2", "  kd_Ns_per_m: [2");
  const std::string message = ErrorOf(text);
  EXPECT_THAT(message, HasSubstr("test.yaml:"));
  EXPECT_THAT(message, HasSubstr("YAML syntax error"));
}

TEST(YamlConfigErrors, EmptyDocument) { EXPECT_THAT(ErrorOf(""), HasSubstr("test.yaml: the config is empty")); }

TEST(YamlConfigErrors, NotAMapping) { EXPECT_THAT(ErrorOf("- 1\n- 2\n"), HasSubstr("expected a mapping")); }

TEST(LoadProcessConfig, MissingFileNamesThePath) {
  try {
    LoadProcessConfig("/nonexistent/teleop/master.yaml");
    FAIL() << "expected teleop::Error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("/nonexistent/teleop/master.yaml"));
  }
}

TEST(LoadProcessConfig, MessagesCarryTheRealFileName) {
  const test::ScopedTempDir dir("cfg");
  const auto path = dir.path() / "teleop.yaml";
  {
    std::ofstream out(path);
    out << Replace(kBase, "rate_hz: 1000", "rate_hz: 100");
  }
  try {
    LoadProcessConfig(path.string());
    ADD_FAILURE() << "expected teleop::Error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path.string() + ":3:10: key 'rate_hz': ", 0), 0u) << e.what();
  }
}

}  // namespace
}  // namespace teleop::config
