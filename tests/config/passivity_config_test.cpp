// The `passivity:` section (docs/configuration.md, docs/stability.md "Time-domain passivity"): modes, the damping
// bound, refusal of energy_exchange over CAN, and the errors a user sees.
#include <gtest/gtest.h>

#include <string>

#include "teleop/config/yaml_config.hpp"
#include "test_utilities/config_text.hpp"

namespace teleop::config {
namespace {

using test::ErrorOf;
using test::ExpectError;

std::string Config(const std::string& passivity, const std::string& link =
                                                     "  bind: \"127.0.0.1:47001\"\n"
                                                     "  peer: \"127.0.0.1:47002\"\n") {
  return "role: slave\ndof: 2\nrate_hz: 1000\nlink:\n" + link + "  security: {mode: insecure}\n" +
         "law: {kp_N_per_m: 600, kd_Ns_per_m: 2, max_force_N: 4}\n"
         "device: {backend: loopback, loopback: {mass_kg: 0.036, damping_Ns_per_m: 0.49}}\n" +
         passivity;
}

TEST(PassivityConfig, AbsentIsOffWithTheDofAndTheLawsForceLimit) {
  const ProcessConfig c = ParseProcessConfig(Config(""), "test.yaml");
  EXPECT_EQ(c.passivity.mode, control::PassivityMode::kOff);
  EXPECT_EQ(c.passivity.dof, 2);
  EXPECT_EQ(c.passivity.max_damping_Ns_per_m.size(), 2);
  EXPECT_EQ(c.passivity.max_force_N, 4.0);
}

TEST(PassivityConfig, ModesAndThePerDofDampingBound) {
  ProcessConfig c =
      ParseProcessConfig(Config("passivity: {mode: energy_exchange, max_damping_Ns_per_m: [20, 5]}\n"), "test.yaml");
  EXPECT_EQ(c.passivity.mode, control::PassivityMode::kEnergyExchange);
  EXPECT_EQ(c.passivity.max_damping_Ns_per_m[0], 20.0);
  EXPECT_EQ(c.passivity.max_damping_Ns_per_m[1], 5.0);
  c = ParseProcessConfig(Config("passivity: {mode: observer, max_damping_Ns_per_m: 12}\n"), "test.yaml");
  EXPECT_EQ(c.passivity.mode, control::PassivityMode::kObserver);
  EXPECT_EQ(c.passivity.max_damping_Ns_per_m[1], 12.0);
  c = ParseProcessConfig(Config("passivity: {mode: off}\n"), "test.yaml");
  EXPECT_EQ(c.passivity.mode, control::PassivityMode::kOff);
}

TEST(PassivityConfig, BadValuesNameTheKey) {
  const std::string bad_mode = Config("passivity: {mode: passive, max_damping_Ns_per_m: 20}\n");
  ExpectError(bad_mode, "passive", "passivity.mode", "must be 'off', 'observer' or 'energy_exchange'");
  const std::string missing = Config("passivity: {mode: observer}\n");
  ExpectError(missing, "{mode: observer}", "passivity", "max_damping_Ns_per_m is required with mode observer");
  const std::string negative = Config("passivity: {mode: observer, max_damping_Ns_per_m: -1}\n");
  ExpectError(negative, "-1", "passivity.max_damping_Ns_per_m", "N·s/m");
  const std::string wrong_count = Config("passivity: {mode: observer, max_damping_Ns_per_m: [1, 2, 3]}\n");
  EXPECT_NE(ErrorOf(wrong_count).find("passivity.max_damping_Ns_per_m"), std::string::npos);
  const std::string unknown = Config("passivity: {mode: observer, max_damping: 20}\n");
  EXPECT_NE(ErrorOf(unknown).find("max_damping"), std::string::npos);
}

TEST(PassivityConfig, EnergyExchangeIsRefusedOverCan) {
  for (const char* link : {"  transport: can\n  can: {interface: vcan0}\n",
                           "  transport: emulated-can\n  can: {bus: \"127.0.0.1:47400\"}\n"}) {
    const std::string text = Config("passivity: {mode: energy_exchange, max_damping_Ns_per_m: 20}\n", link);
    const std::string message = ErrorOf(text);
    EXPECT_NE(message.find("key 'passivity.mode'"), std::string::npos) << message;
    EXPECT_NE(message.find("CAN frame layout has no room"), std::string::npos) << message;
    EXPECT_NE(message.find("use mode 'observer'"), std::string::npos) << message;
  }
  // The local observer/controller is fine over CAN.
  const ProcessConfig c = ParseProcessConfig(Config("passivity: {mode: observer, max_damping_Ns_per_m: 20}\n",
                                                    "  transport: can\n  can: {interface: vcan0}\n"),
                                             "test.yaml");
  EXPECT_EQ(c.passivity.mode, control::PassivityMode::kObserver);
}

}  // namespace
}  // namespace teleop::config
