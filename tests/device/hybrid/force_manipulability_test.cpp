#include "device/hybrid/force_manipulability.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "device/hybrid/hybrid_rig.hpp"

namespace teleop::device::hybrid {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// For the rhombus, JᵀJ = l²[[1, cos Δ], [cos Δ, 1]], so F_min = τ / (l·sqrt(1 + |cos Δ|)).
TEST(ForceManipulability, RhombusMatchesClosedForm) {
  const FiveBar fb{FiveBarConfig{}};
  for (double delta : {40.0, 75.0, 90.0, 120.0, 154.0}) {
    const Eigen::Vector2d q{(90.0 - delta / 2) * kDeg, (90.0 + delta / 2) * kDeg};
    Eigen::Matrix2d jac;
    ASSERT_TRUE(fb.Jacobian(q, jac));
    const FmeAxes axes = ForceManipulability(jac, 22.2);
    EXPECT_NEAR(axes.min_force_N, 22.2 / (0.2 * std::sqrt(1.0 + std::abs(std::cos(delta * kDeg)))), 1e-9);
    EXPECT_NEAR(axes.max_force_N, 22.2 / (0.2 * std::sqrt(1.0 - std::abs(std::cos(delta * kDeg)))), 1e-9);
  }
}

// Every point of the FME curve (eq. 2 with ‖τ‖ = τ_max) lies between the two semi-axes, and τ = JᵀF holds (eq. 1).
TEST(ForceManipulability, CurveSatisfiesEquationOneAndLiesBetweenTheAxes) {
  const FiveBar fb{FiveBarConfig{}};
  Eigen::Vector2d q;
  ASSERT_TRUE(fb.Inverse({0.1, 0.15}, q));
  Eigen::Matrix2d jac;
  ASSERT_TRUE(fb.Jacobian(q, jac));
  const FmeAxes axes = ForceManipulability(jac, 22.2);
  for (const auto& f : FmeCurve(jac, 22.2, 360)) {
    EXPECT_NEAR((jac.transpose() * f).norm(), 22.2, 1e-9);
    EXPECT_GE(f.norm(), axes.min_force_N - 1e-9);
    EXPECT_LE(f.norm(), axes.max_force_N + 1e-9);
  }
}

// The paper's claims (§2.2): motors > 80 N in all directions over the workspace. Ours: 80.55 N at (0, 90 mm), the
// workspace corner nearest the folded singularity. Brakes: the paper says > 36 N; eqs 1–2 with 4 N·m × 5 give
// 72.57 N (docs/hybrid.md discusses the factor of two). 5 mm grid.
TEST(ForceManipulability, PaperWorkspaceNumbers) {
  const HybridRigConfig rig{};
  const FmeMap map = MapForceManipulability(FiveBar{rig.geometry}, rig.motor.MaxJointTorqueNm(),
                                            rig.brake.max_torque_Nm * rig.brake.pulley_ratio, 0.005);
  EXPECT_EQ(map.workspace_points, 77 * 47);  // the whole 380 mm × 230 mm rectangle is reachable
  EXPECT_GT(map.min_motor_force_N, 80.0);
  EXPECT_NEAR(map.min_motor_force_N, 80.55, 0.05);
  EXPECT_NEAR(map.min_brake_force_N, 72.57, 0.05);
  EXPECT_GT(map.min_brake_force_N, 36.0);
  EXPECT_NEAR(map.min_motor_at_m.y(), 0.090, 1e-9);
  EXPECT_GT(map.min_singularity_margin, 0.4);  // "no singularity exists" in the workspace
}

TEST(ForceManipulability, SingularJacobianGivesZero) {
  EXPECT_EQ(ForceManipulability(Eigen::Matrix2d::Zero(), 10.0).min_force_N, 0.0);
  Eigen::Matrix2d nan_jac = Eigen::Matrix2d::Identity();
  nan_jac(0, 0) = std::nan("");
  EXPECT_EQ(ForceManipulability(nan_jac, 10.0).max_force_N, 0.0);
}

}  // namespace
}  // namespace teleop::device::hybrid
