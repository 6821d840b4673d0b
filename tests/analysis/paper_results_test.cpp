// The paper's cases and the trends of its Figs. 2 and 7-14, predicted with the default finger bounds.

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdlib>
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

// The Fig. 2 system has K_pm = K_dm = 0: the master does not feel the slave, so the slave's loop is closed on its
// own — a mass-damper (m_s ẍ + b_s ẋ = u, held over the period) under u_k = -(K_ps + K_sVF) x_k
// - K_vs (x_k - x_{k-1})/T (eq. 9 about the equilibrium, backward-difference velocity of eq. 20). Its exact ZOH
// step is written out here (not with the library's state matrix), and its stability decided by the Jury test
// on the characteristic cubic (no eigenvalue solver): an independent value for the limit, which §4.4 says does
// not depend on the operator.
bool DecoupledSlaveLoopIsStable(double fixture_N_per_m) {
  const double m = kPaperSlaveDevice.mass_kg;
  const double b = kPaperSlaveDevice.damping_Ns_per_m;
  const double t = 1.0 / 500.0;
  const double k = 600.0 + fixture_N_per_m;  // K_ps + K_sVF
  const double kv = 2.0;                     // K_vs
  const double a = std::exp(-b / m * t);
  const double c1 = (1.0 - a) * m / b;            // x_{k+1} per v_k
  const double c2 = (t - (1.0 - a) * m / b) / b;  // x_{k+1} per u_k
  const double c3 = (1.0 - a) / b;                // v_{k+1} per u_k
  const double g1 = -(k + kv / t);                // u_k per x_k
  const double g2 = kv / t;                       // u_k per x_{k-1}
  // State (x_k, v_k, x_{k-1}).
  const std::array<std::array<double, 3>, 3> s = {
      {{1.0 + c2 * g1, c1, c2 * g2}, {c3 * g1, a, c3 * g2}, {1.0, 0.0, 0.0}}};
  // det(zI - S) = z^3 + a2 z^2 + a1 z + a0.
  const double trace = s[0][0] + s[1][1] + s[2][2];
  const double minors = (s[0][0] * s[1][1] - s[0][1] * s[1][0]) + (s[0][0] * s[2][2] - s[0][2] * s[2][0]) +
                        (s[1][1] * s[2][2] - s[1][2] * s[2][1]);
  const double det = s[0][0] * (s[1][1] * s[2][2] - s[1][2] * s[2][1]) -
                     s[0][1] * (s[1][0] * s[2][2] - s[1][2] * s[2][0]) +
                     s[0][2] * (s[1][0] * s[2][1] - s[1][1] * s[2][0]);
  const double a2 = -trace;
  const double a1 = minors;
  const double a0 = -det;
  // Jury conditions for a monic cubic.
  return 1.0 + a2 + a1 + a0 > 0.0 && 1.0 - a2 + a1 - a0 > 0.0 && std::abs(a0) < 1.0 &&
         std::abs(a0 * a0 - 1.0) > std::abs(a0 * a2 - a1);
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
  // The paper: 3000 N/m vibrates (Fig. 2).
  EXPECT_LT(limit.max_stable_stiffness_N_per_m, 3000.0);
  // The independent value: bisect the Jury test to 1e-6 relative.
  ASSERT_TRUE(DecoupledSlaveLoopIsStable(0.0));
  ASSERT_FALSE(DecoupledSlaveLoopIsStable(3000.0));
  double lo = 0.0;
  double hi = 3000.0;
  while (hi - lo > 1e-6 * hi) {
    const double mid = 0.5 * (lo + hi);
    (DecoupledSlaveLoopIsStable(mid) ? lo : hi) = mid;
  }
  // 0.2 %: the analysis searches its limit to 0.1 % from below (StabilityLimit), the Jury value is exact.
  EXPECT_NEAR(limit.max_stable_stiffness_N_per_m, lo, 2e-3 * lo) << "Jury limit " << lo << " N/m";
  EXPECT_LE(limit.max_stable_stiffness_N_per_m, lo * (1.0 + 1e-9)) << "the search must approach from below";
  // And it does not depend on the operator (§4.4): one plausible finger gives the same limit.
  EXPECT_NEAR(FindMaxStableStiffness(system, FixtureSide::kSlave, plausible).max_stable_stiffness_N_per_m, lo,
              2e-3 * lo);
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
