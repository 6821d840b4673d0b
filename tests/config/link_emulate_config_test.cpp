// The `link.emulate` section (docs/link-emulation.md): its keys, units, ranges and the errors a user sees, and the
// link MakeLink opens from it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"
#include "teleop/link/link_config.hpp"
#include "teleop/transport/impaired_link.hpp"
#include "test_utilities/config_text.hpp"

namespace teleop::config {
namespace {

using ::testing::HasSubstr;

std::string Config(const std::string& emulate, const std::string& transport = "udp") {
  const std::string link = transport == "udp"
                               ? "  transport: udp\n  bind: \"127.0.0.1:47999\"\n  peer: \"127.0.0.1:9\"\n"
                               : "  transport: " + transport + "\n";
  return "role: slave\ndof: 1\nrate_hz: 1000\nlink:\n" + link + "  security: {mode: insecure}\n  emulate:\n" + emulate +
         "law: {kp_N_per_m: 600, kd_Ns_per_m: 2}\n"
         "device: {backend: loopback, loopback: {mass_kg: 0.036, damping_Ns_per_m: 0.49}}\n";
}

TEST(LinkEmulateConfig, EveryKeyFillsTheImpairmentsInSIUnits) {
  const ProcessConfig c = ParseProcessConfig(
      Config("    seed: 42\n    delay_ms: 20\n    jitter_ms: 5\n    loss_probability: 0.05\n"
             "    burst: {enter_probability: 0.01, exit_probability: 0.25, loss_probability: 0.9}\n"
             "    duplicate_probability: 0.02\n    reorder_probability: 0.03\n    corrupt_probability: 0.04\n"
             "    bandwidth_bit_per_s: 2000000\n    queue_ms: 10\n    outages: [[1.0, 0.1], [2.5, 0.5]]\n"),
      "test.yaml");
  const auto& e = c.link.emulate;
  EXPECT_TRUE(e.enabled);
  EXPECT_EQ(e.seed, 42u);
  const transport::ImpairmentConfig& i = e.impairments;
  EXPECT_DOUBLE_EQ(i.delay_s, 0.020);
  EXPECT_DOUBLE_EQ(i.jitter_s, 0.005);
  EXPECT_DOUBLE_EQ(i.loss_probability, 0.05);
  EXPECT_DOUBLE_EQ(i.burst.enter_probability, 0.01);
  EXPECT_DOUBLE_EQ(i.burst.exit_probability, 0.25);
  EXPECT_DOUBLE_EQ(i.burst.loss_probability, 0.9);
  EXPECT_DOUBLE_EQ(i.duplicate_probability, 0.02);
  EXPECT_DOUBLE_EQ(i.reorder_probability, 0.03);
  EXPECT_DOUBLE_EQ(i.corrupt_probability, 0.04);
  EXPECT_DOUBLE_EQ(i.bandwidth_bit_per_s, 2e6);
  EXPECT_DOUBLE_EQ(i.queue_limit_s, 0.010);
  ASSERT_EQ(i.outages.size(), 2u);
  EXPECT_DOUBLE_EQ(i.outages[1].start_s, 2.5);
  EXPECT_DOUBLE_EQ(i.outages[1].duration_s, 0.5);
}

// A delay that steps mid-run (issue 32's re-check test): ascending steps in SI units; out of order refused.
TEST(LinkEmulateConfig, DelayStepsInSIUnitsAndAscending) {
  const ProcessConfig c = ParseProcessConfig(
      Config("    delay_ms: 1\n    delay_steps: [{at_s: 3, delay_ms: 60}, {at_s: 8, delay_ms: 1}]\n"), "test.yaml");
  const auto& steps = c.link.emulate.impairments.delay_steps;
  ASSERT_EQ(steps.size(), 2u);
  EXPECT_DOUBLE_EQ(steps[0].at_s, 3.0);
  EXPECT_DOUBLE_EQ(steps[0].delay_s, 0.060);
  EXPECT_DOUBLE_EQ(steps[1].at_s, 8.0);
  EXPECT_DOUBLE_EQ(steps[1].delay_s, 0.001);
  EXPECT_THAT(
      [] { ParseProcessConfig(Config("    delay_steps: [{at_s: 8, delay_ms: 60}, {at_s: 3, delay_ms: 1}]\n"), "t"); },
      ::testing::ThrowsMessage<Error>(HasSubstr("ascending order of at_s")));
  EXPECT_THAT([] { ParseProcessConfig(Config("    delay_steps: [{at_s: 1, delay_ms: -5}]\n"), "t"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("delay_ms")));
  EXPECT_THAT([] { ParseProcessConfig(Config("    delay_steps: [{at_s: 1}]\n"), "t"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("delay_ms")));
  EXPECT_THAT([] { ParseProcessConfig(Config("    delay_steps: 5\n"), "t"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("list of {at_s, delay_ms}")));
}

// link.delay_recheck: defaults from the struct, every key read, ranges and the hysteresis checked.
TEST(DelayRecheckConfig, KeysDefaultsAndRanges) {
  const auto with = [](const std::string& recheck) {
    std::string text = Config("    delay_ms: 1\n");
    const std::string at = "  emulate:\n";
    text.insert(text.find(at), "  delay_recheck: " + recheck + "\n");
    return ParseProcessConfig(text, "test.yaml");
  };
  const link::LinkConfig::DelayRecheck defaults = with("{}").link.delay_recheck;
  EXPECT_FALSE(defaults.enabled);
  EXPECT_DOUBLE_EQ(defaults.window_s, 1.0);
  EXPECT_EQ(defaults.on_unstable, link::LinkConfig::DelayRecheck::OnUnstable::kEvent);
  const link::LinkConfig::DelayRecheck r =
      with(
          "{enabled: true, window_s: 0.5, percentile: 0.9, trigger_ratio: 2, recover_ratio: 1.5, recover_hold_s: 1, "
          "margin: 0.8, max_force_rate_N_per_s: 40, max_penetration_m: 0.005, on_unstable: decouple}")
          .link.delay_recheck;
  EXPECT_TRUE(r.enabled);
  EXPECT_DOUBLE_EQ(r.window_s, 0.5);
  EXPECT_DOUBLE_EQ(r.percentile, 0.9);
  EXPECT_DOUBLE_EQ(r.trigger_ratio, 2.0);
  EXPECT_DOUBLE_EQ(r.recover_ratio, 1.5);
  EXPECT_DOUBLE_EQ(r.recover_hold_s, 1.0);
  EXPECT_DOUBLE_EQ(r.margin, 0.8);
  EXPECT_DOUBLE_EQ(r.max_force_rate_N_per_s, 40.0);
  EXPECT_DOUBLE_EQ(r.max_penetration_m, 0.005);
  EXPECT_EQ(r.on_unstable, link::LinkConfig::DelayRecheck::OnUnstable::kDecouple);
  EXPECT_EQ(with("{on_unstable: passivity}").link.delay_recheck.on_unstable,
            link::LinkConfig::DelayRecheck::OnUnstable::kPassivity);
  // Switching passivity on at run time needs the controller's damping bound, given with mode off.
  EXPECT_THAT([&] { with("{enabled: true, on_unstable: passivity}"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("passivity.max_damping_Ns_per_m")));
  EXPECT_EQ(ParseProcessConfig(Config("    delay_ms: 1\n")
                                       .insert(Config("    delay_ms: 1\n").find("  emulate:\n"),
                                               "  delay_recheck: {enabled: true, on_unstable: "
                                               "passivity}\n") +
                                   "passivity: {mode: off, max_damping_Ns_per_m: 100}\n",
                               "test.yaml")
                .passivity.max_damping_Ns_per_m[0],
            100.0);
  EXPECT_THAT([&] { with("{percentile: 1.5}"); }, ::testing::ThrowsMessage<Error>(HasSubstr("percentile")));
  EXPECT_THAT([&] { with("{trigger_ratio: 1}"); }, ::testing::ThrowsMessage<Error>(HasSubstr("trigger_ratio")));
  EXPECT_THAT([&] { with("{trigger_ratio: 1.2, recover_ratio: 1.5}"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("must be at most trigger_ratio")));
  EXPECT_THAT([&] { with("{margin: 0}"); }, ::testing::ThrowsMessage<Error>(HasSubstr("margin")));
  EXPECT_THAT([&] { with("{max_force_rate_N_per_s: 0}"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("max_force_rate_N_per_s")));
  EXPECT_THAT([&] { with("{on_unstable: panic}"); },
              ::testing::ThrowsMessage<Error>(HasSubstr("event, decouple or passivity")));
  EXPECT_THAT([&] { with("{windows: 1}"); }, ::testing::ThrowsMessage<Error>(HasSubstr("windows")));
}

TEST(LinkEmulateConfig, AbsentOrDisabledMeansThePlainLink) {
  const std::string plain =
      "role: slave\ndof: 1\nrate_hz: 1000\nlink: {security: {mode: insecure}, transport: udp, bind: "
      "\"127.0.0.1:47999\", peer: \"127.0.0.1:9\"}\n"
      "law: {kp_N_per_m: 600, kd_Ns_per_m: 2}\n"
      "device: {backend: loopback, loopback: {mass_kg: 0.036, damping_Ns_per_m: 0.49}}\n";
  EXPECT_FALSE(ParseProcessConfig(plain, "test.yaml").link.emulate.enabled);
  ProcessConfig off = ParseProcessConfig(Config("    enabled: false\n    delay_ms: 5\n"), "test.yaml");
  EXPECT_FALSE(off.link.emulate.enabled);
  off.link.udp.bind_port = 0;  // any free port
  const auto link = link::MakeLink(off.link, proto::SenderRole::kSlave);
  EXPECT_EQ(transport::EmulationCountersOf(*link), nullptr);
}

TEST(LinkEmulateConfig, MakeLinkWrapsTheConfiguredTransport) {
  ProcessConfig c = ParseProcessConfig(Config("    delay_ms: 5\n    loss_probability: 0.1\n"), "test.yaml");
  c.link.udp.bind_port = 0;  // any free port
  const auto link = link::MakeLink(c.link, proto::SenderRole::kSlave);
  ASSERT_NE(transport::EmulationCountersOf(*link), nullptr);
  EXPECT_THAT(link->Describe(), HasSubstr("udp"));
  EXPECT_THAT(link->Describe(), HasSubstr("emulate (receive side: delay 5.000 ms, loss 0.100, seed 1)"));
}

TEST(LinkEmulateConfig, ErrorsNameFileLineKeyAndUnit) {
  using test::ExpectError;
  std::string t = Config("    delay_ms: -1\n");
  ExpectError(t, "-1", "link.emulate.delay_ms", "must be in 0..10000 ms");
  t = Config("    loss_probability: 1.5\n");
  ExpectError(t, "1.5", "link.emulate.loss_probability", "must be in 0..1 (probability)");
  t = Config("    jitter_ms: .nan\n");
  ExpectError(t, ".nan", "link.emulate.jitter_ms", "");
  t = Config("    reorder_probability: 0.1\n    delay_ms: 1\n");
  ExpectError(t, "0.1\n", "link.emulate.reorder_probability", "needs link.emulate.delay_ms > one loop period");
  t = Config("    burst: {enter_probability: 0.1, exit_probability: 0}\n");
  ExpectError(t, "0}", "link.emulate.burst.exit_probability", "a burst never ends");
  t = Config("    burst: {enter_probability: 0.1}\n");
  ExpectError(t, "{enter", "link.emulate.burst.exit_probability", "missing required key");
  t = Config("    queue_ms: 10\n");
  ExpectError(t, "10\n", "link.emulate.queue_ms", "only with link.emulate.bandwidth_bit_per_s");
  t = Config("    bandwidth_bit_per_s: 10\n");
  ExpectError(t, "10\n", "link.emulate.bandwidth_bit_per_s", "bit/s");
  t = Config("    outages: [[1.0]]\n");
  ExpectError(t, "[1.0]]", "link.emulate.outages[0]", "[start_s, duration_s]");
  t = Config("    outages: [[1.0, 0]]\n");
  ExpectError(t, "0]]", "link.emulate.outages[0][1]", "s (duration)");
  t = Config("    outages: 3\n");
  ExpectError(t, "3", "link.emulate.outages", "list of [start_s, duration_s] pairs");
  t = Config("    seed: -4\n");
  ExpectError(t, "-4", "link.emulate.seed", "integer");
  t = Config("    delay: 5\n");
  ExpectError(t, "delay:", "link.emulate.delay", "delay_ms");
}

TEST(LinkEmulateConfig, WorksOnTheEmulatedCanBusToo) {
  const ProcessConfig c = ParseProcessConfig(Config("    delay_ms: 3\n", "emulated-can"), "test.yaml");
  EXPECT_EQ(c.link.transport, "emulated-can");
  EXPECT_TRUE(c.link.emulate.enabled);
  EXPECT_DOUBLE_EQ(c.link.emulate.impairments.delay_s, 0.003);
}

}  // namespace
}  // namespace teleop::config
