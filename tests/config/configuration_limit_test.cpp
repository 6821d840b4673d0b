// config::ConfigurationLimit::Decide (docs/arms.md, "Stability"): lowered below (1 − margin) × the limit, raised
// with hysteresis, restored to the configured stiffness, the ramp at the bounded force rate. The worker on an arm:
// tests/device/arm/arm_limit_test.cpp (ArmRuntimeLimit.*).

#include "teleop/config/configuration_limit.hpp"

#include <gtest/gtest.h>

#include <optional>

namespace teleop::config {
namespace {

using Kind = ConfigurationLimit::Action::Kind;

ConfigurationLimit::Evaluation At(double limit_N_per_m) {
  ConfigurationLimit::Evaluation e;
  e.valid = true;
  e.limit_N_per_m = limit_N_per_m;
  e.at.where = "q = (0) rad";
  return e;
}

TEST(ConfigurationLimitDecide, LowersRaisesWithHysteresisAndRestores) {
  ConfigurationLimit::Options o;
  o.margin = 0.2;
  o.hysteresis = 0.1;
  o.max_force_rate_N_per_s = 20.0;
  o.max_penetration_m = 0.01;
  constexpr double kConfigured = 2000.0;
  // (1 − 0.2) × 3000 = 2400 ≥ 2000: nothing to do.
  EXPECT_FALSE(ConfigurationLimit::Decide(o, kConfigured, kConfigured, At(3000.0)));
  // (1 − 0.2) × 2000 = 1600 < 2000: lowered to 1600 over |Δk| · x / rate = 400 · 0.01 / 20 = 0.2 s.
  const std::optional<ConfigurationLimit::Action> lowered =
      ConfigurationLimit::Decide(o, kConfigured, 2000.0, At(2000.0));
  ASSERT_TRUE(lowered);
  EXPECT_EQ(lowered->kind, Kind::kLowered);
  EXPECT_DOUBLE_EQ(lowered->fixture_N_per_m, 1600.0);
  EXPECT_DOUBLE_EQ(lowered->ramp_s, 0.2);
  EXPECT_NE(lowered->message.find("q = (0) rad"), std::string::npos) << lowered->message;
  // Within the limit search's 1 % above (1 − 0.2) × 2000: left as it is.
  EXPECT_FALSE(ConfigurationLimit::Decide(o, kConfigured, 1610.0, At(2000.0)));
  // Within the hysteresis band: 0.8 × 2100 / 1.1 = 1527 < 1600 · 1.1: stays.
  EXPECT_FALSE(ConfigurationLimit::Decide(o, kConfigured, 1600.0, At(2100.0)));
  // 0.8 × 2300 / 1.1 = 1673 < 1760: stays; 0.8 × 2500 / 1.1 = 1818 ≥ 1760: raised to it.
  EXPECT_FALSE(ConfigurationLimit::Decide(o, kConfigured, 1600.0, At(2300.0)));
  const std::optional<ConfigurationLimit::Action> raised =
      ConfigurationLimit::Decide(o, kConfigured, 1600.0, At(2500.0));
  ASSERT_TRUE(raised);
  EXPECT_EQ(raised->kind, Kind::kRaised);
  EXPECT_NEAR(raised->fixture_N_per_m, 0.8 * 2500.0 / 1.1, 1e-9);
  // 0.8 × 3000 / 1.1 = 2182 ≥ 2000: restored to the configured stiffness, never above it.
  const std::optional<ConfigurationLimit::Action> restored =
      ConfigurationLimit::Decide(o, kConfigured, 1600.0, At(3000.0));
  ASSERT_TRUE(restored);
  EXPECT_EQ(restored->kind, Kind::kRestored);
  EXPECT_DOUBLE_EQ(restored->fixture_N_per_m, kConfigured);
  EXPECT_DOUBLE_EQ(restored->ramp_s, 400.0 * 0.01 / 20.0);
  // The coupling unstable at the configuration (limit 0): lowered to 0.
  const std::optional<ConfigurationLimit::Action> zero = ConfigurationLimit::Decide(o, kConfigured, 1600.0, At(0.0));
  ASSERT_TRUE(zero);
  EXPECT_DOUBLE_EQ(zero->fixture_N_per_m, 0.0);
  // No evaluation (immobile along every normal): nothing.
  EXPECT_FALSE(ConfigurationLimit::Decide(o, kConfigured, 1600.0, ConfigurationLimit::Evaluation{}));
}

}  // namespace
}  // namespace teleop::config
