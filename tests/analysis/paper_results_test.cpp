// The paper's cases and the trends of its Figs. 2 and 7-14, predicted with the default finger bounds.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "teleop/analysis/human_bounds.hpp"
#include "teleop/analysis/limit_sweep.hpp"
#include "teleop/analysis/stability_limit.hpp"

namespace teleop::analysis {
namespace {

const std::vector<HumanModel>& Humans() {
  static const std::vector<HumanModel> humans = MakeHumanGrid(DefaultFingerBounds(), 4);
  return humans;
}

TEST(PaperFig2, SlaveFixtureOf3000IsPredictedUnstable) {
  // K_ps = 600 N/m, K_vs = 2 N·s/m, K_sVF = 3000 N/m at 500 Hz, all other gains 0.
  SampledTeleoperator system;
  system.rate_hz = 500.0;
  system.gains.kps_N_per_m = 600.0;
  system.gains.kvs_Ns_per_m = 2.0;
  system.gains.slave_fixture_N_per_m = 3000.0;
  const WorstCase worst = EvaluateWorstCase(system, Humans());
  EXPECT_LT(worst.min_damping_ratio, 0.0);
  EXPECT_GT(worst.spectral_radius, 1.0);
  // With the master unactuated no operator can help: every operator is unstable, the median one included.
  const std::vector<HumanModel> plausible{{0.006, 2.0, 300.0, 8.0}};
  EXPECT_LT(EvaluateWorstCase(system, plausible).min_damping_ratio, 0.0);
  const StabilityLimit limit = FindMaxStableStiffness(system, FixtureSide::kSlave, Humans());
  EXPECT_LT(limit.max_stable_stiffness_N_per_m, 3000.0);
  EXPECT_GT(limit.max_stable_stiffness_N_per_m, 500.0);
}

TEST(PaperFigs7And11, LimitRisesWithTheSamplingRate) {
  SampledTeleoperator system;
  system.gains = LawGains::Symmetric(600.0, 2.0);
  const std::vector<double> rates{250.0, 500.0, 1000.0, 2000.0, 4000.0};
  for (FixtureSide side : {FixtureSide::kSlave, FixtureSide::kMaster}) {
    const auto curve = SweepLimit(system, side, Humans(), SweepVariable::kRateHz, rates);
    for (std::size_t i = 1; i < curve.size(); ++i) {
      EXPECT_GT(curve[i].limit.max_stable_stiffness_N_per_m, 1.5 * curve[i - 1].limit.max_stable_stiffness_N_per_m)
          << ToString(side) << " at " << rates[i] << " Hz";
    }
  }
}

TEST(PaperFigs8And12, DerivativeGainMovesTheLimitStronglyPositionGainWeakly) {
  SampledTeleoperator system;
  system.rate_hz = 500.0;
  system.gains = LawGains::Symmetric(600.0, 2.0);
  for (FixtureSide side : {FixtureSide::kSlave, FixtureSide::kMaster}) {
    const std::vector<double> kp{200.0, 1000.0};
    const std::vector<double> kd{2.0, 6.0};
    const auto by_kp = SweepLimit(system, side, Humans(), SweepVariable::kKp, kp);
    const auto by_kd = SweepLimit(system, side, Humans(), SweepVariable::kKd, kd);
    const double kp_change =
        std::abs(std::log(by_kp[1].limit.max_stable_stiffness_N_per_m / by_kp[0].limit.max_stable_stiffness_N_per_m));
    const double kd_change =
        std::abs(std::log(by_kd[1].limit.max_stable_stiffness_N_per_m / by_kd[0].limit.max_stable_stiffness_N_per_m));
    // K_p ×5 moves the limit by less than 30 %; K_d ×3 more than doubles it.
    EXPECT_LT(kp_change, std::log(1.3)) << ToString(side);
    EXPECT_GT(kd_change, std::log(2.0)) << ToString(side);
    EXPECT_GT(by_kd[1].limit.max_stable_stiffness_N_per_m, by_kd[0].limit.max_stable_stiffness_N_per_m);
  }
}

TEST(PaperFig14, PassivityIsMoreConservativeThanTheEigenvalueLimitOnTheMasterSide) {
  // Unilateral, K_ps = 1000 N/m, K_ds = 6 N·s/m: a haptic device against a virtual wall.
  SampledTeleoperator system;
  system.unilateral = true;
  system.gains.kps_N_per_m = 1000.0;
  system.gains.kds_Ns_per_m = 6.0;
  for (double rate : {250.0, 500.0, 1000.0, 2000.0}) {
    system.rate_hz = rate;
    const StabilityLimit limit = FindMaxStableStiffness(system, FixtureSide::kMaster, Humans());
    EXPECT_NEAR(limit.passivity_bound_N_per_m, 2.0 * 0.41 * rate, 1e-6);
    EXPECT_GT(limit.max_stable_stiffness_N_per_m, 1.5 * limit.passivity_bound_N_per_m) << rate;
  }
}

TEST(PaperFig10, UnilateralSlaveLimitDoesNotDependOnTheOperator) {
  // With the master saturated the operator is out of the slave's loop.
  SampledTeleoperator system;
  system.unilateral = true;
  system.rate_hz = 1000.0;
  system.gains.kps_N_per_m = 1000.0;
  system.gains.kds_Ns_per_m = 6.0;
  const std::vector<HumanModel> small{{0.003, 0.6, 74.0, 2.0}};
  const std::vector<HumanModel> large{{0.009, 5.1, 950.0, 20.0}};
  const double a = FindMaxStableStiffness(system, FixtureSide::kSlave, small).max_stable_stiffness_N_per_m;
  const double b = FindMaxStableStiffness(system, FixtureSide::kSlave, large).max_stable_stiffness_N_per_m;
  EXPECT_NEAR(a, b, 2e-3 * a);
  // And the bilateral slave limit is higher than the unilateral one at the same gains (§4.4: saturation makes
  // the slave vibrate easier).
  SampledTeleoperator bilateral = system;
  bilateral.unilateral = false;
  bilateral.gains = LawGains::Symmetric(1000.0, 6.0);
  EXPECT_GT(FindMaxStableStiffness(bilateral, FixtureSide::kSlave, Humans()).max_stable_stiffness_N_per_m, 1.1 * a);
}

}  // namespace
}  // namespace teleop::analysis
