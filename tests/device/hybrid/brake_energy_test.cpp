// "A brake never adds energy": seeded randomized property tests over states and commands.
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <cstdlib>
#include <random>

#include "device/hybrid/brake_friction_solver.hpp"
#include "device/hybrid/hybrid_rig.hpp"

namespace teleop::device::hybrid {
namespace {

/// TELEOP_PROPERTY_COUNT raises the number of cases (default 20000).
int PropertyCount() {
  const char* env = std::getenv("TELEOP_PROPERTY_COUNT");
  return env != nullptr ? std::max(1, std::atoi(env)) : 20000;
}

TEST(BrakeFrictionSolver, NeverAddsEnergyAndObeysFrictionLaw) {
  std::mt19937_64 rng(20260101);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = PropertyCount();
  for (int k = 0; k < n; ++k) {
    // Random SPD inertia (joint inertias 0.001–0.1 kg·m², coupling up to 90 % of the geometric mean).
    const double m11 = 0.05 + 0.049 * u(rng);
    const double m22 = 0.05 + 0.049 * u(rng);
    const double m12 = 0.9 * u(rng) * std::sqrt(m11 * m22);
    Eigen::Matrix2d m;
    m << m11, m12, m12, m22;
    const Eigen::Matrix2d w = m.inverse();
    const Eigen::Vector2d v0{5.0 * u(rng), 5.0 * u(rng)};
    const Eigen::Vector2d cap{20.0 * (0.5 + 0.5 * u(rng)), 20.0 * (0.5 + 0.5 * u(rng))};
    const double h = 1e-4 * (1.5 + u(rng));
    const BrakeImpulse b = SolveBrakeImpulse(v0, w, cap, h);
    ASSERT_TRUE(b.solved) << "case " << k;
    const double e0 = 0.5 * v0.dot(m * v0);
    const double e1 = 0.5 * b.velocity_rad_per_s.dot(m * b.velocity_rad_per_s);
    ASSERT_LE(e1, e0 * (1.0 + 1e-12) + 1e-15) << "case " << k;
    for (int i = 0; i < 2; ++i) {
      ASSERT_LE(std::abs(b.impulse_Nms(i)), cap(i) * h * (1.0 + 1e-9)) << "case " << k;
      // Opposes the joint's final motion (λ·v⁺ ≤ 0).
      ASSERT_LE(b.impulse_Nms(i) * b.velocity_rad_per_s(i), 1e-12) << "case " << k;
    }
  }
}

TEST(BrakeFrictionSolver, HoldsAStuckJointAndSlipsBeyondCapacity) {
  const Eigen::Matrix2d w = Eigen::Matrix2d::Identity() * 10.0;
  // Capacity enough to stop joint 0 within the step (needs 0.01/10/1e-3 = 1 N·m), not joint 1.
  const BrakeImpulse b = SolveBrakeImpulse({0.01, 2.0}, w, {5.0, 5.0}, 1e-3);
  ASSERT_TRUE(b.solved);
  EXPECT_DOUBLE_EQ(b.velocity_rad_per_s(0), 0.0);
  EXPECT_NEAR(b.velocity_rad_per_s(1), 2.0 - 10.0 * 5.0 * 1e-3, 1e-12);
  EXPECT_FALSE(SolveBrakeImpulse({std::nan(""), 0.0}, w, {1.0, 1.0}, 1e-3).solved);
}

// The rig with the motors off and brakes commanded at random: the brakes' cumulative work is never positive and,
// with no hand, the kinetic energy never grows.
TEST(HybridRig, BrakesNeverAddEnergyOverRandomRuns) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int runs = std::max(1, PropertyCount() / 200);
  for (int r = 0; r < runs; ++r) {
    HybridRigConfig cfg;
    cfg.initial_position_m = {0.15 * u(rng), 0.2 + 0.08 * u(rng)};
    HybridRig rig(cfg);
    // Throw the handle with a short hand push, then let only the brakes act.
    const Eigen::Vector2d push{60.0 * u(rng), 60.0 * u(rng)};
    for (int k = 0; k < 10; ++k) rig.Step(Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), push, 1e-3);
    double energy = rig.KineticEnergyJ();
    const double brake_work_before = rig.state().brake_energy_J;
    for (int k = 0; k < 100 && rig.kinematics().InWorkspace(rig.state().position_m); ++k) {
      const Eigen::Vector2d brake_cmd{2.0 + 2.0 * u(rng), 2.0 + 2.0 * u(rng)};
      rig.Step(Eigen::Vector2d::Zero(), brake_cmd, Eigen::Vector2d::Zero(), 1e-3);
      const double now = rig.KineticEnergyJ();
      // Semi-implicit Euler on a configuration-dependent inertia: allow 1e-6 J of integration error per step.
      ASSERT_LE(now, energy + 1e-6) << "run " << r << " step " << k;
      energy = now;
    }
    EXPECT_LE(rig.state().brake_energy_J, brake_work_before + 1e-12) << "run " << r;
  }
}

}  // namespace
}  // namespace teleop::device::hybrid

namespace teleop::device::hybrid {
namespace {

// Static vs sliding: a stuck joint holds up to static_ratio × (brake + joint friction capacity) before it slips; once
// sliding it feels the sliding capacity. Brake shaft 2 N·m: capacity (2 + 0.08) × 5 + 0.1 = 10.5 N·m, static 11.55.
TEST(HybridRig, StaticTorqueAboveSlidingTorque) {
  HybridRig rig{HybridRigConfig{}};
  const Eigen::Vector2d brake{2.0, 2.0};
  for (int k = 0; k < 500; ++k) rig.Step(Eigen::Vector2d::Zero(), brake, Eigen::Vector2d::Zero(), 1e-3);
  ASSERT_NEAR(rig.state().brake_capacity_joint_Nm(0), 1.1 * ((2.0 + 0.08) * 5.0 + 0.1), 0.01);
  for (int k = 0; k < 100; ++k) rig.Step({11.0, 0.0}, brake, Eigen::Vector2d::Zero(), 1e-3);  // below static
  EXPECT_EQ(rig.state().joint_velocity_rad_per_s(0), 0.0);
  for (int k = 0; k < 5; ++k) rig.Step({12.0, 0.0}, brake, Eigen::Vector2d::Zero(), 1e-3);  // above: it slips
  EXPECT_GT(std::abs(rig.state().joint_velocity_rad_per_s(0)), 0.0);
  EXPECT_NEAR(rig.state().brake_capacity_joint_Nm(0), (2.0 + 0.08) * 5.0 + 0.1, 0.01);  // sliding capacity
}

}  // namespace
}  // namespace teleop::device::hybrid
