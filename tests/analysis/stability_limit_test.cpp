// The worst-case stiffness search: what it guarantees, against per-operator searches, and its edge cases.

#include "teleop/analysis/stability_limit.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <vector>

#include "teleop/analysis/damping_ratio.hpp"
#include "teleop/analysis/discrete_model.hpp"
#include "teleop/analysis/human_bounds.hpp"
#include "teleop/error.hpp"

namespace teleop::analysis {
namespace {

double Radius(SampledTeleoperator system, FixtureSide side, const HumanModel& human, double stiffness) {
  system.gains = EffectiveGains(system, side);
  system.gains.fixture(side) = stiffness;
  return SpectralRadius(BuildStateMatrix(system, human));
}

SampledTeleoperator PaperSystem(double rate_hz, double kp, double kd) {
  SampledTeleoperator system;
  system.rate_hz = rate_hz;
  system.gains = LawGains::Symmetric(kp, kd);
  return system;
}

TEST(FindMaxStableStiffness, BracketIsStableBelowUnstableAboveAndWithinTolerance) {
  const auto humans = MakeHumanGrid(DefaultFingerBounds(), 4);
  for (FixtureSide side : {FixtureSide::kMaster, FixtureSide::kSlave}) {
    for (double rate : {500.0, 2000.0}) {
      const SampledTeleoperator system = PaperSystem(rate, 600.0, 2.0);
      const StabilityLimit limit = FindMaxStableStiffness(system, side, humans);
      SCOPED_TRACE(std::string(ToString(side)) + " " + std::to_string(rate));
      const double lo = limit.max_stable_stiffness_N_per_m;
      const double hi = limit.min_unstable_stiffness_N_per_m;
      ASSERT_GT(lo, 0.0);
      EXPECT_LE((hi - lo) / lo, 1e-3);
      double worst = 0.0;
      for (const HumanModel& h : humans) worst = std::max(worst, Radius(system, side, h, lo));
      EXPECT_LE(worst, 1.0 + 1e-9);
      EXPECT_GT(Radius(system, side, limit.limiting_human, hi), 1.0);
      EXPECT_GE(limit.worst_damping_ratio, 0.0);
      EXPECT_LT(limit.worst_damping_ratio, 0.01);  // at the limit the worst mode is nearly undamped
    }
  }
}

TEST(FindMaxStableStiffness, SetLimitIsTheLowestPerOperatorLimit) {
  // A small, varied set: the set's limit equals the minimum of the single-operator limits (to the tolerance).
  const std::vector<HumanModel> humans{{0.003, 0.6, 230.0, 2.0},
                                       {0.009, 0.6, 74.0, 2.0},
                                       {0.006, 2.5, 400.0, 10.0},
                                       {0.009, 5.1, 950.0, 20.0},
                                       {0.003, 1.7, 290.0, 20.0}};
  for (FixtureSide side : {FixtureSide::kMaster, FixtureSide::kSlave}) {
    SampledTeleoperator system = PaperSystem(1000.0, 800.0, 3.0);
    system.peer_delay_samples = 1;
    double lowest = std::numeric_limits<double>::infinity();
    for (const HumanModel& h : humans) {
      const std::vector<HumanModel> one{h};
      lowest = std::min(lowest, FindMaxStableStiffness(system, side, one).max_stable_stiffness_N_per_m);
    }
    const StabilityLimit limit = FindMaxStableStiffness(system, side, humans);
    EXPECT_NEAR(limit.max_stable_stiffness_N_per_m, lowest, 2e-3 * lowest) << ToString(side);
  }
}

TEST(FindMaxStableStiffness, ThreadCountDoesNotChangeTheResult) {
  const auto humans = MakeHumanGrid(DefaultFingerBounds(), 4);
  const SampledTeleoperator system = PaperSystem(1000.0, 600.0, 2.0);
  LimitOptions one;
  one.threads = 1;
  LimitOptions two;
  two.threads = 2;
  const double a = FindMaxStableStiffness(system, FixtureSide::kMaster, humans, one).max_stable_stiffness_N_per_m;
  const double b = FindMaxStableStiffness(system, FixtureSide::kMaster, humans, two).max_stable_stiffness_N_per_m;
  EXPECT_NEAR(a, b, 1e-3 * a);
}

TEST(FindMaxStableStiffness, LawUnstableWithoutFixtureGivesZero) {
  // K_p = 600 N/m with no damping at 500 Hz: the slave's own discrete spring exceeds 2b/T = 490 N/m.
  const auto humans = MakeHumanGrid(DefaultFingerBounds(), 2);
  const StabilityLimit limit = FindMaxStableStiffness(PaperSystem(500.0, 600.0, 0.0), FixtureSide::kSlave, humans);
  EXPECT_TRUE(limit.unstable_without_fixture);
  EXPECT_EQ(limit.max_stable_stiffness_N_per_m, 0.0);
  EXPECT_LT(limit.worst_damping_ratio, 0.0);
}

TEST(FindMaxStableStiffness, RejectsEmptySetsAndBadOptions) {
  const std::vector<HumanModel> none;
  EXPECT_THROW((void)FindMaxStableStiffness(PaperSystem(500.0, 600.0, 2.0), FixtureSide::kSlave, none), Error);
  const std::vector<HumanModel> one{{0.005, 1.0, 200.0, 5.0}};
  LimitOptions bad;
  bad.relative_tolerance = 0.0;
  EXPECT_THROW((void)FindMaxStableStiffness(PaperSystem(500.0, 600.0, 2.0), FixtureSide::kSlave, one, bad), Error);
}

TEST(PassivityBound, ColgateSchenkelOnTheLocalImpedance) {
  SampledTeleoperator unilateral;
  unilateral.unilateral = true;
  unilateral.rate_hz = 500.0;
  unilateral.gains.kps_N_per_m = 1000.0;
  unilateral.gains.kds_Ns_per_m = 6.0;
  // Master: a plain virtual wall on a device with b = 0.41 N·s/m: K < 2b/T.
  EXPECT_NEAR(PassivityBound(unilateral, FixtureSide::kMaster), 2.0 * 0.41 * 500.0, 1e-9);
  unilateral.gains.kvm_Ns_per_m = 0.1;
  EXPECT_NEAR(PassivityBound(unilateral, FixtureSide::kMaster), 2.0 * (0.41 - 0.1) * 500.0, 1e-9);
  // Slave: virtual damping K_ds = 6 exceeds b_s: no stiffness is passive.
  EXPECT_EQ(PassivityBound(unilateral, FixtureSide::kSlave), 0.0);
}

}  // namespace
}  // namespace teleop::analysis
