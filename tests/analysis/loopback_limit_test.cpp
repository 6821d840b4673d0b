// The predicted limit against the loopback plant and the real ThreeChannelLaw in closed loop (the shared harness
// tests/test_utilities/closed_loop.hpp, one-sample link delay as in the processes): with the operator pushing the
// device steadily into the forbidden region, a fixture at 0.9× the predicted limit settles, at 1.1× it keeps
// oscillating. The operator is the one the analysis found limiting.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "teleop/analysis/human_bounds.hpp"
#include "teleop/analysis/stability_limit.hpp"
#include "test_utilities/closed_loop.hpp"

namespace teleop::analysis {
namespace {

struct LoopCase {
  std::string name;
  FixtureSide side;
  double rate_hz;
  LawGains gains;  // fixtures ignored
  bool unilateral;
  int delay;
  bool small_operator_set = false;  ///< 4 operators instead of 512 (the long delays: ~ms per model, docs/stability.md)
  /// The operator's push (N). The soft gain sets transmit a tenth of it to the slave: 30 N keeps the slave as deep
  /// in the region (≥ 0.1 mm) as the shipped gains' 3 N; the system is linear in it.
  double operator_force_N = 3.0;
};

std::ostream& operator<<(std::ostream& out, const LoopCase& c) { return out << c.name; }

test::OneDofSetup MakeSetup(const LoopCase& c, const HumanModel& human, double stiffness) {
  const LawGains g = [&] {
    SampledTeleoperator s;
    s.gains = c.gains;
    s.unilateral = c.unilateral;
    return EffectiveGains(s, c.side);
  }();
  test::OneDofSetup setup;
  setup.rate_hz = c.rate_hz;
  setup.delay_cycles = c.delay;
  setup.kpm_N_per_m = g.kpm_N_per_m;
  setup.kps_N_per_m = g.kps_N_per_m;
  setup.kdm_Ns_per_m = g.kdm_Ns_per_m;
  setup.kds_Ns_per_m = g.kds_Ns_per_m;
  setup.kvm_Ns_per_m = g.kvm_Ns_per_m;
  setup.kvs_Ns_per_m = g.kvs_Ns_per_m;
  (c.side == FixtureSide::kMaster ? setup.master_fixture_N_per_m : setup.slave_fixture_N_per_m) = stiffness;
  setup.human_mass_kg = human.mass_kg;
  setup.human_damping_Ns_per_m = human.damping_Ns_per_m;
  setup.human_stiffness_N_per_m = human.stiffness_N_per_m;
  setup.operator_force_N = c.operator_force_N;  // pushes +x, into the region X > 0
  setup.operator_ramp_s = 0.2;
  return setup;
}

class LoopbackLimit : public ::testing::TestWithParam<LoopCase> {};

TEST_P(LoopbackLimit, SettlesAtNinetyPercentOscillatesAtHundredTenPercent) {
  const LoopCase& c = GetParam();
#ifdef TELEOP_SANITIZED_BUILD
  // 100 samples of delay is a 208-state model searched over the operator grid: 64 s under ASan + UBSan, 1 s in
  // release. The release suite runs it; the sanitizer pass keeps the cases up to 40 samples, the same code paths.
  if (c.delay > 50) GTEST_SKIP() << "the 100-sample case runs in the release suite only";
#endif
  SampledTeleoperator system;
  system.rate_hz = c.rate_hz;
  system.gains = c.gains;
  system.unilateral = c.unilateral;
  system.peer_delay_samples = c.delay;
  const std::vector<double> masses{0.003, 0.009};
  const std::vector<double> dampings{0.62};
  const std::vector<double> stiffnesses{74.0, 830.0};
  const StabilityLimit limit = FindMaxStableStiffness(
      system, c.side,
      c.small_operator_set ? MakeHumanGrid(masses, dampings, stiffnesses) : MakeHumanGrid(DefaultFingerBounds(), 4));
  ASSERT_GT(limit.max_stable_stiffness_N_per_m, 0.0);
  const test::Signal position =
      c.side == FixtureSide::kMaster ? test::Signal::kMasterPosition : test::Signal::kSlavePosition;
  const test::Signal penetration =
      c.side == FixtureSide::kMaster ? test::Signal::kMasterPenetration : test::Signal::kSlavePenetration;

  // 0.9×: after the push the device comes to rest inside the region: the position ripple keeps shrinking (less than
  // half in the last second of what it was in the second one) and is below 10 µm. (The slowest case, the master
  // wall, decays by about 3× per second at 0.9× of its limit.)
  {
    test::ClosedLoop loop(
        test::MakeOneDofConfig(MakeSetup(c, limit.limiting_human, 0.9 * limit.max_stable_stiffness_N_per_m)));
    const auto trace = loop.Run(4.0);
    const test::WindowStats last = test::Stats(trace, position, 3.0, 4.0);
    const test::WindowStats second = test::Stats(trace, position, 1.0, 2.0);
    EXPECT_LT(last.std_dev, 1e-5) << "0.9x did not settle";
    EXPECT_LT(last.std_dev, 0.5 * second.std_dev) << "0.9x is not decaying";
    EXPECT_GT(test::Stats(trace, penetration, 3.0, 4.0).mean, 1e-4) << "the device is not in the region";
  }
  // 1.1×: a sustained oscillation (the growth stops at the unilateral fixture's edge: a limit cycle), as large in
  // the last second as in the second before, and well above the ripple bound.
  {
    test::ClosedLoop loop(
        test::MakeOneDofConfig(MakeSetup(c, limit.limiting_human, 1.1 * limit.max_stable_stiffness_N_per_m)));
    const auto trace = loop.Run(4.0);
    const test::WindowStats earlier = test::Stats(trace, position, 2.0, 3.0);
    const test::WindowStats last = test::Stats(trace, position, 3.0, 4.0);
    EXPECT_GT(last.std_dev, 2e-5) << "1.1x did not oscillate";
    EXPECT_GT(last.std_dev, 0.8 * earlier.std_dev) << "1.1x oscillation is decaying";
  }
}

LawGains Symmetric(double kp, double kd) { return LawGains::Symmetric(kp, kd); }
LawGains SlaveOnly(double kps, double kds) {
  LawGains g;
  g.kps_N_per_m = kps;
  g.kds_Ns_per_m = kds;
  return g;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, LoopbackLimit,
    ::testing::Values(LoopCase{"slave_1000Hz_kp600_kd2", FixtureSide::kSlave, 1000.0, Symmetric(600, 2), false, 1},
                      LoopCase{"master_500Hz_kp600_kd2", FixtureSide::kMaster, 500.0, Symmetric(600, 2), false, 1},
                      LoopCase{"master_unilateral_1000Hz", FixtureSide::kMaster, 1000.0, SlaveOnly(1000, 6), true, 1},
                      LoopCase{"slave_unilateral_500Hz_nodelay", FixtureSide::kSlave, 500.0, SlaveOnly(1000, 6), true,
                               0}),
    [](const ::testing::TestParamInfo<LoopCase>& param_info) { return param_info.param.name; });

// Issue 32: the delay-line model (d samples of peer delay, 8 + 2d states) against the same closed loop with a
// d-sample delay line in each direction, d from 0 to 100 samples (100 ms at 1 kHz), three gain sets: the shipped
// gains (K_p 600, K_d 2), whose limit falls with the delay until the coupling itself goes unstable between 4 and 5
// samples, and two softer sets stable out to 100 samples.
INSTANTIATE_TEST_SUITE_P(
    Delays, LoopbackLimit,
    ::testing::Values(
        LoopCase{"slave_kp600_kd2_delay0", FixtureSide::kSlave, 1000.0, Symmetric(600, 2), false, 0, true},
        LoopCase{"slave_kp600_kd2_delay3", FixtureSide::kSlave, 1000.0, Symmetric(600, 2), false, 3, true},
        LoopCase{"master_kp600_kd2_delay2", FixtureSide::kMaster, 1000.0, Symmetric(600, 2), false, 2, true},
        LoopCase{"slave_kp50_kd1_delay10", FixtureSide::kSlave, 1000.0, Symmetric(50, 1), false, 10, true, 30.0},
        LoopCase{"slave_kp50_kd1_delay40", FixtureSide::kSlave, 1000.0, Symmetric(50, 1), false, 40, true, 30.0},
        LoopCase{"slave_kp20_kd05_delay100", FixtureSide::kSlave, 1000.0, Symmetric(20, 0.5), false, 100, true, 30.0}),
    [](const ::testing::TestParamInfo<LoopCase>& param_info) { return param_info.param.name; });

}  // namespace
}  // namespace teleop::analysis
