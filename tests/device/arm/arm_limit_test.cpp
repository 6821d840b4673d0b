// The fixture's stability at the arm's configuration (docs/arms.md, "Stability"): the sweep keeps only
// configurations near the plane and draws the same ones for the same seed; the start-up check passes the stylus
// rig's fixture and refuses one above the smallest limit over the swept configurations, naming the worst one.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "arm_section.hpp"
#include "arm_sweep.hpp"
#include "teleop/analysis/stability_limit.hpp"
#include "teleop/config/stability_check.hpp"
#include "teleop/control/three_channel_law.hpp"
#include "teleop/control/velocity_estimator.hpp"
#include "teleop/control/virtual_fixture.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/device/loopback.hpp"

namespace teleop::device::arm {
namespace {

const std::string kRobots = TELEOP_ROBOTS_DIR;

ArmSection SevenJointSlave() {
  ArmSection s;
  s.chain.urdf_file = kRobots + "/arm_7dof.urdf";
  s.chain.base_link = "base";
  s.chain.tool_link = "tool";
  s.device.min_manipulability = 0.001;
  s.workspace_origin_m = {0.650393420703, 0.0, 0.339193883457};  // deploy/configs/arm/slave-stylus.yaml
  s.initial_q_rad = {0, 0.6, 0, -1.4, 0, 0.9, 0};
  s.simulation.viscous_Nms_per_rad = 0.5;
  s.fixture_sweep.samples = 2000;
  return s;
}

TEST(ArmSweep, KeepsConfigurationsNearThePlaneTheSameForTheSameSeed) {
  const ArmSection s = SevenJointSlave();
  ArmModel model(BuildArmChain(s.chain), s.gravity_B());
  FixtureSweepConfig c = s.fixture_sweep;
  c.bucket = 0.0;  // every kept configuration on its own
  const Eigen::Vector3d n(0.0, 0.0, -1.0);
  const double offset_B = -0.31;  // the plane z = 0.31 m
  const FixtureSweep a = SweepNearPlane(model, c, 0.5, n, offset_B, 0.001);
  EXPECT_EQ(a.sampled, 2000);
  ASSERT_GT(a.near_plane, 10);
  EXPECT_EQ(static_cast<int>(a.buckets.size()), a.near_plane - a.skipped);
  for (const SweptConfiguration& b : a.buckets) {
    EXPECT_LE(std::abs(n.dot(b.p_BT) - offset_B), c.plane_distance_m);
    ASSERT_TRUE(model.Update(b.q, JointVector(model.joint_count())));
    EXPECT_NEAR(b.along_normal.mass_kg, model.ApparentMass(n), 1e-9 * b.along_normal.mass_kg);
  }
  const FixtureSweep again = SweepNearPlane(model, c, 0.5, n, offset_B, 0.001);
  ASSERT_EQ(again.buckets.size(), a.buckets.size());
  EXPECT_EQ(again.buckets.front().q, a.buckets.front().q);
  c.seed = 2;
  const FixtureSweep other = SweepNearPlane(model, c, 0.5, n, offset_B, 0.001);
  EXPECT_FALSE(other.buckets.front().q == a.buckets.front().q) << "the seed does not change the draw";
  // Buckets: fewer analyses than configurations, each standing for at least one.
  c.seed = 1;
  c.bucket = 0.05;
  const FixtureSweep bucketed = SweepNearPlane(model, c, 0.5, n, offset_B, 0.001);
  EXPECT_LT(bucketed.buckets.size(), a.buckets.size());
  int represented = 0;
  for (const SweptConfiguration& b : bucketed.buckets) represented += b.bucket_size;
  EXPECT_EQ(represented, static_cast<int>(a.buckets.size()));
}

/// The stylus rig's slave (deploy/configs/arm/slave-stylus.yaml) in code, with the fixture stiffness given.
config::ProcessConfig StylusSlave(double fixture_N_per_m, const ArmSection& section) {
  config::ProcessConfig c;
  c.role = Role::kSlave;
  c.dof = 3;
  c.loop.rate_hz = 1000.0;
  c.law = control::ThreeChannelLaw::ZeroGains(Role::kSlave, 3);
  c.law.kp_N_per_m = DofVector::Constant(3, 300.0);
  c.law.kd_Ns_per_m = DofVector::Constant(3, 2.0);
  c.law.kv_Ns_per_m = DofVector::Constant(3, 5.0);
  c.law.velocity_filter_hz = 200.0;
  c.law.fixture = control::ForbiddenRegionFixture::HalfSpace(3, 2, -0.03, -1.0, fixture_N_per_m);
  c.device = DeviceConfig::Of("arm", 3, section);
  c.stability.peer.mass_kg = 0.056;
  c.stability.peer.damping_Ns_per_m = 0.1;
  c.stability.peer.kv_Ns_per_m = DofVector::Constant(3, 0.5);
  c.source_path = "slave-stylus.yaml";
  return c;
}

TEST(ArmStability, StartUpRefusesAFixtureAboveTheSmallestLimitNamingTheWorstConfiguration) {
#ifdef TELEOP_SANITIZED_BUILD
  GTEST_SKIP() << "dozens of stability analyses: minutes under ASan + UBSan; the release run checks this (the sweep "
                  "itself runs here in ArmSweep.*)";
#endif
  const ArmSection section = SevenJointSlave();
  const config::StabilityReport pass = config::CheckProcessStability(StylusSlave(2000.0, section));
  ASSERT_TRUE(pass.sweep.has_value());
  EXPECT_TRUE(pass.stable()) << config::DescribeFailure(StylusSlave(2000.0, section), pass);
  EXPECT_GT(pass.sweep->analysed, 5);
  const double limit = pass.sweep->check.limit.max_stable_stiffness_N_per_m;
  EXPECT_GT(limit, 2000.0);
  // The sweep finds configurations where the limit is lower than at the start configuration along z.
  EXPECT_LT(limit, pass.axes[2].limit.max_stable_stiffness_N_per_m);
  EXPECT_NE(config::DescribePass(StylusSlave(2000.0, section), pass).find("over the arm's configurations"),
            std::string::npos);

  // Above the smallest limit but below the start configuration's: only the sweep refuses it.
  const double between = 0.5 * (limit + pass.axes[2].limit.max_stable_stiffness_N_per_m);
  const config::ProcessConfig stiff = StylusSlave(between, section);
  const config::StabilityReport fail = config::CheckProcessStability(stiff);
  EXPECT_FALSE(fail.stable());
  EXPECT_TRUE(fail.axes[2].stable) << "the start configuration alone would have passed it";
  ASSERT_TRUE(fail.sweep.has_value());
  // The same worst configuration (the draw is seeded); its limit to the search's 0.1 % (the bisection starts from the
  // configured stiffness).
  EXPECT_EQ(fail.sweep->worst.where, pass.sweep->worst.where);
  EXPECT_NEAR(fail.sweep->check.limit.max_stable_stiffness_N_per_m, limit, 2e-3 * limit);
  const std::string message = config::DescribeFailure(stiff, fail);
  for (const char* part : {"is above the predicted stability limit", "at the worst of", "q = (", "tool at (",
                           "apparent mass", "teleop-arm check --config slave-stylus.yaml"}) {
    EXPECT_NE(message.find(part), std::string::npos) << part << " missing from: " << message;
  }
  EXPECT_NE(message.find(fail.sweep->worst.where), std::string::npos) << message;

  // No sweep: fixture_sweep.samples 0, or a stability.device model given in the config.
  ArmSection off = section;
  off.fixture_sweep.samples = 0;
  EXPECT_FALSE(config::CheckProcessStability(StylusSlave(between, off)).sweep.has_value());
  config::ProcessConfig given = StylusSlave(between, section);
  given.stability.device.mass_kg = 3.0;
  given.stability.device.damping_Ns_per_m = 1.0;
  EXPECT_FALSE(config::CheckProcessStability(given).sweep.has_value());
}

/// The slave's z (m, from its working point) over a run of an in-process pair, stepped as
/// tests/test_utilities/closed_loop.hpp steps one: a 3-DOF loopback master (the analysis' peer, 0.056 kg,
/// 0.1 N·s/m) with the operator `human` pushing it down by 3 N (ramped over 0.2 s), the simulated 7-joint arm as the
/// slave with the fixture z < -2 mm of `stiffness`, one sample of delay each way.
std::vector<double> RunArmPair(const ArmSection& section, const config::ProcessConfig& process,
                               const analysis::HumanModel& human, double stiffness, double seconds) {
  constexpr double kPeriod_s = 0.001;
  LoopbackPlantConfig mc = LoopbackPlantConfig::PaperMaster(3);
  mc.mass_kg = 0.056;
  mc.damping_Ns_per_m = 0.1;
  mc.human.enabled = true;
  mc.human.mass_kg = human.mass_kg;
  mc.human.damping_Ns_per_m = human.damping_Ns_per_m;
  mc.human.stiffness_N_per_m = human.stiffness_N_per_m;
  mc.human.segment_count = 2;
  using Kind = OperatorSegment::Kind;
  mc.human.segments[0] = {Kind::kRamp, 0.0, 0.2, 0.0, -3.0, 0.0, 0.0, 0.0, 2};
  mc.human.segments[1] = {Kind::kHold, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2};
  LoopbackPlant master(mc);
  std::unique_ptr<ArmDevice> slave = MakeArmDevice(section);
  control::ThreeChannelLaw::Config ml = control::ThreeChannelLaw::ZeroGains(Role::kMaster, 3);
  ml.kp_N_per_m = process.law.kp_N_per_m;
  ml.kd_Ns_per_m = process.law.kd_Ns_per_m;
  ml.kv_Ns_per_m = DofVector::Constant(3, 0.5);
  ml.velocity_filter_hz = process.law.velocity_filter_hz;
  control::ThreeChannelLaw::Config sl = process.law;
  sl.fixture = control::ForbiddenRegionFixture::HalfSpace(3, 2, -0.002, -1.0, stiffness);
  control::ThreeChannelLaw master_law(ml);
  control::ThreeChannelLaw slave_law(sl);
  control::VelocityEstimator master_velocity({3, ml.velocity_filter_hz});
  control::VelocityEstimator slave_velocity({3, sl.velocity_filter_hz});
  struct Wire {
    DofVector position_m, velocity_m_per_s, force_N;
    bool valid = false;
  };
  Wire to_slave, to_master;
  std::vector<double> z;
  Reading mr, sr;
  const int cycles = static_cast<int>(std::lround(seconds / kPeriod_s));
  for (int k = 0; k < cycles; ++k) {
    master.Read(mr);
    slave->Read(sr);
    const Wire from_master = to_slave;
    const Wire from_slave = to_master;
    to_slave = {mr.position_m, master_velocity.Step(mr.position_m, kPeriod_s), mr.force_N, true};
    to_master = {sr.position_m, slave_velocity.Step(sr.position_m, kPeriod_s), sr.force_N, true};
    const auto input = [](const Reading& own, const Wire& peer) {
      control::ThreeChannelLaw::Input in;
      in.position_m = own.position_m;
      in.peer_valid = peer.valid;
      if (peer.valid) {
        in.peer_position_m = peer.position_m;
        in.peer_velocity_m_per_s = peer.velocity_m_per_s;
        in.peer_force_N = peer.force_N.size() == 3 ? peer.force_N : DofVector::Zero(3);
      }
      return in;
    };
    const control::ThreeChannelLaw::Output mo = master_law.Step(input(mr, from_slave), kPeriod_s);
    const control::ThreeChannelLaw::Output so = slave_law.Step(input(sr, from_master), kPeriod_s);
    master.Write(Command::Force(mo.command_N));
    slave->Write(Command::Force(so.command_N));
    master.Update(kPeriod_s);
    slave->Update(kPeriod_s);
    z.push_back(sr.position_m[2]);
    EXPECT_EQ(sr.faults, kFaultNone) << "cycle " << k;
  }
  return z;
}

/// Standard deviation of x over [from_s, to_s) at 1 kHz.
double StdDev(const std::vector<double>& x, double from_s, double to_s) {
  const auto a = static_cast<std::size_t>(from_s * 1000.0);
  const auto b = static_cast<std::size_t>(to_s * 1000.0);
  double mean = 0.0;
  for (std::size_t i = a; i < b; ++i) mean += x[i];
  mean /= static_cast<double>(b - a);
  double sq = 0.0;
  for (std::size_t i = a; i < b; ++i) sq += (x[i] - mean) * (x[i] - mean);
  return std::sqrt(sq / static_cast<double>(b - a));
}

// Not a test (disabled; it asserts nothing): the probe behind docs/arms.md's "Not built yet". Prints the arm's
// apparent mass along -z at the stylus rig's start configuration, its damping as the analysis takes it
// (b / |J_vᵀ·n|², low frequency) and at high frequency (m_n²·b·|M⁻¹·J_vᵀ·n|²), the limit with each, and the slave's
// z ripple in the pair above at multiples of the first limit:
//   build/tests/device_arm_test --gtest_also_run_disabled_tests --gtest_filter='ArmStability.DISABLED_*'
TEST(ArmStability, DISABLED_ProbeTheSimulatedPairAtMultiplesOfThePredictedLimit) {
  ArmSection section = SevenJointSlave();
  section.simulation.coulomb_Nm = 0.0;
  section.posture_q_rad = section.initial_q_rad;
  section.device.torque.posture_stiffness_Nm_per_rad = 5.0;
  section.device.torque.posture_damping_Nms_per_rad = 1.0;
  config::ProcessConfig process = StylusSlave(0.0, section);
  ArmModel model(BuildArmChain(section.chain), section.gravity_B());
  JointVector q(model.joint_count());
  for (int i = 0; i < q.size(); ++i) q[i] = section.initial_q_rad[static_cast<std::size_t>(i)];
  ASSERT_TRUE(model.Update(q, JointVector(model.joint_count())));
  const Eigen::Vector3d n(0.0, 0.0, -1.0);
  const NormalModel along = ModelAlong(model, n, section.simulation.viscous_Nms_per_rad);
  const JointVector Jt_n(model.J_BT().topRows<3>().transpose() * n);
  const JointVector x = model.SolveInertia(Jt_n);
  const double hf = along.mass_kg * along.mass_kg * section.simulation.viscous_Nms_per_rad * x.squaredNorm();
  std::printf("m_n %.3f kg, damping %.3f N·s/m (low frequency), %.3f N·s/m (high frequency)\n", along.mass_kg,
              along.damping_Ns_per_m, hf);
  for (double b : {along.damping_Ns_per_m, hf}) {
    process.stability.device.mass_kg = along.mass_kg;
    process.stability.device.damping_Ns_per_m = b;
    const analysis::StabilityLimit limit = analysis::FindMaxStableStiffness(
        config::StabilityModel(process, 2), analysis::FixtureSide::kSlave, config::StabilityOperators(process));
    std::printf("damping %.3f N·s/m: limit %.0f N/m, limiting operator m %.3f kg b %.2f N·s/m k %.0f N/m\n", b,
                limit.max_stable_stiffness_N_per_m, limit.limiting_human.mass_kg, limit.limiting_human.damping_Ns_per_m,
                limit.limiting_human.stiffness_N_per_m);
    if (b != along.damping_Ns_per_m) continue;
    for (double f : {0.9, 1.5, 2.0, 3.0, 5.0, 8.0}) {
      const std::vector<double> z =
          RunArmPair(section, process, limit.limiting_human, f * limit.max_stable_stiffness_N_per_m, 3.0);
      std::printf("  %.1fx: z std %.2e m in 1-2 s, %.2e m in 2-3 s, z at 3 s %.5f m\n", f, StdDev(z, 1.0, 2.0),
                  StdDev(z, 2.0, 3.0), z.back());
    }
  }
}

}  // namespace
}  // namespace teleop::device::arm
