// The fixture's stability at the arm's configuration (docs/arms.md, "Stability"): the sweep keeps only
// configurations near the plane and draws the same ones for the same seed; the start-up check passes the stylus
// rig's fixture and refuses one above the smallest limit over the swept configurations, naming the worst one.

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "arm_section.hpp"
#include "arm_sweep.hpp"
#include "teleop/config/stability_check.hpp"
#include "teleop/control/virtual_fixture.hpp"
#include "teleop/device/device_registry.hpp"

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

}  // namespace
}  // namespace teleop::device::arm
