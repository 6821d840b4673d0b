// The fixture's stability at the arm's configuration (docs/arms.md, "Stability"): the sweep keeps only
// configurations near the plane and draws the same ones for the same seed; the start-up check passes the stylus
// rig's fixture and refuses one above the smallest limit over the swept configurations, naming the worst one.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "arm_section.hpp"
#include "arm_sweep.hpp"
#include "teleop/analysis/stability_limit.hpp"
#include "teleop/config/configuration_limit.hpp"
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
                               const analysis::HumanModel& human, double stiffness, double seconds,
                               std::vector<double>* vz = nullptr) {
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
    if (vz != nullptr) vz->push_back(sr.velocity_m_per_s[2]);
    EXPECT_EQ(sr.faults, kFaultNone) << "cycle " << k;
  }
  return z;
}

/// Root mean square of x over [from_s, to_s) at 1 kHz.
double Rms(const std::vector<double>& x, double from_s, double to_s) {
  const auto a = static_cast<std::size_t>(from_s * 1000.0);
  const auto b = std::min(x.size(), static_cast<std::size_t>(to_s * 1000.0));
  double sq = 0.0;
  for (std::size_t i = a; i < b; ++i) sq += x[i] * x[i];
  return std::sqrt(sq / static_cast<double>(b - a));
}

/// x with its period-2 component removed: the mean of each sample and the one before. The simulated arm's tool
/// velocity carries an alternation from one cycle to the next of about ±2.5 mm/s at every fixture stiffness (0.9 to
/// 10x the limit alike), which hides the fixture's oscillation in a plain RMS.
std::vector<double> TwoSampleMean(const std::vector<double>& x) {
  std::vector<double> m(x.size(), 0.0);
  for (std::size_t i = 1; i < x.size(); ++i) m[i] = 0.5 * (x[i] + x[i - 1]);
  return m;
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

/// The pair above, its slave at the stylus rig's start configuration (Coulomb friction off, a posture spring), and
/// the analysis' limit there with the arm's apparent mass and low-frequency damping along -z (ModelAlong).
struct StartConfigurationPair {
  ArmSection section;
  config::ProcessConfig process;
  NormalModel along;
  analysis::StabilityLimit limit;
};

StartConfigurationPair PairAtTheStartConfiguration() {
  StartConfigurationPair p{SevenJointSlave(), {}, {}, {}};
  p.section.simulation.coulomb_Nm = 0.0;
  p.section.posture_q_rad = p.section.initial_q_rad;
  p.section.device.torque.posture_stiffness_Nm_per_rad = 5.0;
  p.section.device.torque.posture_damping_Nms_per_rad = 1.0;
  p.process = StylusSlave(0.0, p.section);
  ArmModel model(BuildArmChain(p.section.chain), p.section.gravity_B());
  JointVector q(model.joint_count());
  for (int i = 0; i < q.size(); ++i) q[i] = p.section.initial_q_rad[static_cast<std::size_t>(i)];
  EXPECT_TRUE(model.Update(q, JointVector(model.joint_count())));
  p.along = ModelAlong(model, Eigen::Vector3d(0.0, 0.0, -1.0), p.section.simulation.viscous_Nms_per_rad);
  p.process.stability.device.mass_kg = p.along.mass_kg;
  p.process.stability.device.damping_Ns_per_m = p.along.damping_Ns_per_m;
  p.limit = analysis::FindMaxStableStiffness(config::StabilityModel(p.process, 2), analysis::FixtureSide::kSlave,
                                             config::StabilityOperators(p.process));
  return p;
}

// Issue 28.5's closed-loop test: at the configuration, a fixture just below the predicted limit settles and one
// well above it oscillates. "Well above" is 8x: the analysis is conservative for this arm by 6-8x (docs/arms.md,
// "Stability": about 3.5x from the damping model, the rest from the scenario), so 1.1x cannot be asked. Measured by
// the envelope of the slave's velocity along z (RMS over 0.5 s windows) once the push has settled (from 1.5 s).
TEST(ArmStability, TheSimulatedArmSettlesBelowThePredictedLimitAndOscillatesAtEightTimesIt) {
  const StartConfigurationPair p = PairAtTheStartConfiguration();
  const double limit = p.limit.max_stable_stiffness_N_per_m;
  ASSERT_GT(limit, 1000.0);
  constexpr double kSeconds = 2.5;
  std::vector<double> below_v, above_v;
  RunArmPair(p.section, p.process, p.limit.limiting_human, 0.9 * limit, kSeconds, &below_v);
  RunArmPair(p.section, p.process, p.limit.limiting_human, 8.0 * limit, kSeconds, &above_v);
  below_v = TwoSampleMean(below_v);
  above_v = TwoSampleMean(above_v);
  const double below_early = Rms(below_v, 1.5, 2.0), below_late = Rms(below_v, 2.0, 2.5);
  const double above_early = Rms(above_v, 1.5, 2.0), above_late = Rms(above_v, 2.0, 2.5);
  std::printf(
      "limit %.0f N/m (m_n %.3f kg, b_n %.3f N·s/m); v_z RMS in 1.5-2 s, 2-2.5 s: 0.9x %.3g, %.3g m/s; 8x %.3g, "
      "%.3g m/s\n",
      limit, p.along.mass_kg, p.along.damping_Ns_per_m, below_early, below_late, above_early, above_late);
  EXPECT_LT(below_late, 0.5 * below_early) << "0.9x the predicted limit: the ripple decays";
  EXPECT_GE(above_late, 0.7 * above_early) << "8x: the oscillation is sustained (or grows)";
  EXPECT_GT(above_late, 10.0 * below_late) << "8x oscillates, 0.9x settles";
}

// The run-time limit (config::ConfigurationLimit) on the arm's own configuration model: the arm moves from the
// stylus rig's start configuration toward the configuration of least apparent mass and damping along the plane's
// normal that the start-up sweep finds (docs/arms.md, "Stability") and back. The published limit falls and rises;
// the fixture is lowered below it at the bounded force rate and restored to the configured stiffness.
TEST(ArmRuntimeLimit, TheLimitFallsTowardTheLightConfigurationAndTheFixtureRampsDownAtTheBoundedRateAndBack) {
#ifdef TELEOP_SANITIZED_BUILD
  GTEST_SKIP() << "ten limit searches: seconds under ASan + UBSan; the release run checks this";
#endif
  ArmSection section = SevenJointSlave();
  section.fixture_sweep.samples = 0;
  const auto joints = [](std::initializer_list<double> values) {
    JointVector q(static_cast<Eigen::Index>(values.size()));
    Eigen::Index i = 0;
    for (const double v : values) q[i++] = v;
    return q;
  };
  const JointVector q_start = joints({0, 0.6, 0, -1.4, 0, 0.9, 0});  // deploy/configs/arm/slave-stylus.yaml
  const JointVector q_light = joints({0.096, 1.850, 0.171, 0.369, -1.737, -0.081, -2.220});  // the sweep's worst
  const auto at = [&](double s) {
    device::DeviceConfiguration c;
    c.count = 7;
    for (int i = 0; i < 7; ++i) c.values[static_cast<std::size_t>(i)] = q_start[i] + s * (q_light[i] - q_start[i]);
    return c;
  };
  const device::DeviceBackend* backend = device::FindDevice("arm");
  ASSERT_NE(backend, nullptr);
  ASSERT_TRUE(backend->configuration_model);
  device::ConfigurationLimitOptions options;
  options.margin = 0.1;
  options.hysteresis = 0.01;
  options.max_force_rate_N_per_s = 50.0;
  options.max_penetration_m = 0.005;

  device::DeviceConfiguration published = at(0.0);
  std::vector<double> limits;
  std::vector<config::ConfigurationLimit::Action> actions;
  const auto make = [&](double stiffness) {
    const config::ProcessConfig process = StylusSlave(stiffness, section);
    return std::make_unique<config::ConfigurationLimit>(
        process, options, backend->configuration_model(process.device),
        [&](device::DeviceConfiguration& out) {
          out = published;
          return true;
        },
        [&](double limit) { limits.push_back(limit); },
        [&](const config::ConfigurationLimit::Action& a) { actions.push_back(a); });
  };
  // The limits at both ends, then a configured stiffness that passes at the start and not at the light end.
  const config::ConfigurationLimit::Evaluation start = make(1000.0)->Evaluate(at(0.0));
  const config::ConfigurationLimit::Evaluation light = make(1000.0)->Evaluate(at(1.0));
  ASSERT_TRUE(start.valid && light.valid);
  std::printf("start: %.0f N/m (%.2f kg, %.2f N·s/m); light: %.0f N/m (%.2f kg, %.2f N·s/m)\n", start.limit_N_per_m,
              start.at.mass_kg, start.at.damping_Ns_per_m, light.limit_N_per_m, light.at.mass_kg,
              light.at.damping_Ns_per_m);
  EXPECT_LT(light.at.mass_kg, 0.7 * start.at.mass_kg);
  ASSERT_LT(light.limit_N_per_m, start.limit_N_per_m / (1.0 + 2.0 * options.hysteresis));
  const double configured = (1.0 - options.margin) * start.limit_N_per_m / (1.0 + options.hysteresis);
  const auto limit_worker = make(configured);
  double accepted = configured;  // what a `teleop-ctl stiffness` command changes (TeleopNode's accepted stiffness)
  limit_worker->SetConfiguredSource([&accepted] { return accepted; });

  const std::vector<double> path = {0.0, 0.5, 1.0, 1.0, 0.5, 0.0};
  std::vector<double> fixture;
  for (const double s : path) {
    published = at(s);
    ASSERT_TRUE(limit_worker->Step());
    fixture.push_back(limit_worker->fixture_N_per_m());
  }
  ASSERT_EQ(limits.size(), path.size());
  EXPECT_LT(limits[2], limits[0]) << "the limit falls toward the light configuration";
  EXPECT_NEAR(limits[2], light.limit_N_per_m, 0.02 * light.limit_N_per_m);
  EXPECT_GT(limits[5], limits[2]) << "and rises again";
  EXPECT_DOUBLE_EQ(fixture[0], configured) << "nothing to do at the start configuration";
  EXPECT_DOUBLE_EQ(fixture[2], (1.0 - options.margin) * limits[2]) << "lowered to (1 - margin) x the limit";
  EXPECT_DOUBLE_EQ(fixture.back(), configured) << "back to the configured stiffness";
  ASSERT_GE(actions.size(), 2u);
  EXPECT_EQ(actions.front().kind, config::ConfigurationLimit::Action::Kind::kLowered);
  EXPECT_EQ(actions.back().kind, config::ConfigurationLimit::Action::Kind::kRestored);
  double previous = configured;
  for (const config::ConfigurationLimit::Action& a : actions) {
    ASSERT_NE(a.kind, config::ConfigurationLimit::Action::Kind::kFailed) << a.message;
    // The ramp's force rate at max_penetration_m: |Δk| · x_max / ramp_s, never above the bound.
    const double rate = std::abs(a.fixture_N_per_m - previous) * options.max_penetration_m / a.ramp_s;
    EXPECT_LE(rate, options.max_force_rate_N_per_s * (1.0 + 1e-12)) << a.message;
    EXPECT_LE(a.fixture_N_per_m, configured) << "never above the configured stiffness";
    previous = a.fixture_N_per_m;
  }
  // An operator's stiffer fixture, accepted while the arm is at the start configuration: lowered under the limit
  // there, not left at the stiffness the config had.
  accepted = 1.2 * configured;
  ASSERT_TRUE(limit_worker->Step());
  EXPECT_EQ(actions.back().kind, config::ConfigurationLimit::Action::Kind::kLowered);
  EXPECT_DOUBLE_EQ(limit_worker->fixture_N_per_m(), (1.0 - options.margin) * limits.back());
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
    for (double f : {0.9, 3.0, 5.0, 6.0, 8.0, 10.0}) {
      std::vector<double> v;
      const std::vector<double> z =
          RunArmPair(section, process, limit.limiting_human, f * limit.max_stable_stiffness_N_per_m, 3.0, &v);
      v = TwoSampleMean(v);
      std::printf("  %4.1fx: v_z RMS (two-sample mean) per 0.5 s from 0.5 s:", f);
      for (double t = 0.5; t < 2.9; t += 0.5) std::printf(" %.2e", Rms(v, t, t + 0.5));
      std::printf(" m/s; z std %.2e m in 2-3 s, z at 3 s %.5f m\n", StdDev(z, 2.0, 3.0), z.back());
    }
  }
}

}  // namespace
}  // namespace teleop::device::arm
