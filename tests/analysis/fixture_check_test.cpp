// The start-up check the processes run: verdict, message, refusal and the --allow-unstable override.

#include "teleop/analysis/fixture_check.hpp"

#include <gtest/gtest.h>

#include <string>

#include "teleop/error.hpp"

namespace teleop::analysis {
namespace {

SampledTeleoperator ProcessLike(double slave_fixture_N_per_m) {
  SampledTeleoperator system;
  system.rate_hz = 1000.0;
  system.peer_delay_samples = 1;  // what the processes use
  system.gains = LawGains::Symmetric(600.0, 2.0);
  system.gains.slave_fixture_N_per_m = slave_fixture_N_per_m;
  return system;
}

TEST(CheckFixture, BelowTheLimitPassesAboveItIsRefusedNamingTheLimit) {
  const FixtureCheck ok = CheckFixture(ProcessLike(2000.0), FixtureSide::kSlave);
  EXPECT_TRUE(ok.stable) << ok.message;
  EXPECT_GT(ok.at_configured.min_damping_ratio, 0.0);
  EXPECT_NO_THROW(EnforceFixtureLimit(ok, false));

  const FixtureCheck bad = CheckFixture(ProcessLike(8000.0), FixtureSide::kSlave);
  EXPECT_FALSE(bad.stable);
  EXPECT_LT(bad.at_configured.min_damping_ratio, 0.0);
  const double limit = bad.limit.max_stable_stiffness_N_per_m;
  EXPECT_GT(limit, 2000.0);
  EXPECT_LT(limit, 8000.0);
  EXPECT_NE(bad.message.find("UNSTABLE"), std::string::npos);
  try {
    EnforceFixtureLimit(bad, false);
    FAIL() << "expected a refusal";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("refusing to start"), std::string::npos);
    EXPECT_NE(what.find(std::to_string(limit)), std::string::npos) << what;
    EXPECT_NE(what.find("--allow-unstable"), std::string::npos);
  }
  EXPECT_NO_THROW(EnforceFixtureLimit(bad, true));  // the override for experiments
}

TEST(CheckFixture, TheConfiguredStiffnessIsJudgedDirectly) {
  // Just below and just above the limit the verdict follows the eigenvalues.
  const FixtureCheck probe = CheckFixture(ProcessLike(1000.0), FixtureSide::kSlave);
  const double limit = probe.limit.max_stable_stiffness_N_per_m;
  EXPECT_TRUE(CheckFixture(ProcessLike(0.99 * limit), FixtureSide::kSlave).stable);
  EXPECT_FALSE(CheckFixture(ProcessLike(1.01 * limit), FixtureSide::kSlave).stable);
}

TEST(CheckFixture, InvalidSystemThrows) {
  SampledTeleoperator system = ProcessLike(1000.0);
  system.slave.mass_kg = -1.0;
  EXPECT_THROW((void)CheckFixture(system, FixtureSide::kSlave), Error);
}

}  // namespace
}  // namespace teleop::analysis
