#include "device/hybrid/five_bar.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

TEST(FiveBar, PaperRhombusForwardKinematicsIsSumOfProximalLinks) {
  const FiveBar fb{FiveBarConfig{}};
  Eigen::Vector2d p;
  ASSERT_TRUE(fb.Forward({0.0, 90.0 * kDeg}, p));
  EXPECT_NEAR(p.x(), 0.200, 1e-12);
  EXPECT_NEAR(p.y(), 0.200, 1e-12);
  ASSERT_TRUE(fb.Forward({30.0 * kDeg, 150.0 * kDeg}, p));
  EXPECT_NEAR(p.x(), 0.0, 1e-12);
  EXPECT_NEAR(p.y(), 0.4 * std::cos(60.0 * kDeg), 1e-12);  // |p| = 2l·cos(Δ/2), Δ = 120°
}

// Round trips over the whole design rectangle (1 µm), for the paper's geometry and a non-symmetric one.
TEST(FiveBar, InverseThenForwardRoundTripsOverTheWorkspace) {
  FiveBarConfig skew;
  skew.base_separation_m = 0.06;
  skew.proximal_1_m = 0.18;
  skew.distal_2_m = 0.23;
  skew.workspace_y_min_m = 0.15;
  for (const FiveBarConfig& c : {FiveBarConfig{}, skew}) {
    const FiveBar fb{c};
    int checked = 0;
    for (double x = c.workspace_x_min_m; x <= c.workspace_x_max_m; x += 0.01) {
      for (double y = c.workspace_y_min_m; y <= c.workspace_y_max_m; y += 0.01) {
        Eigen::Vector2d q;
        Eigen::Vector2d p;
        if (!fb.Inverse({x, y}, q)) continue;
        ASSERT_TRUE(fb.Forward(q, p)) << x << "," << y;
        EXPECT_NEAR(p.x(), x, 1e-9);
        EXPECT_NEAR(p.y(), y, 1e-9);
        ++checked;
      }
    }
    EXPECT_GT(checked, 300);
  }
}

TEST(FiveBar, PaperWorkspaceRectangleIsReachableWithinJointLimits) {
  const FiveBar fb{FiveBarConfig{}};
  for (double x : {-0.190, 0.0, 0.190}) {
    for (double y : {0.090, 0.200, 0.320}) {
      Eigen::Vector2d q;
      ASSERT_TRUE(fb.Inverse({x, y}, q));
      EXPECT_TRUE(fb.InJointLimits(q)) << x << "," << y << " q=" << q.transpose() / kDeg;
      EXPECT_TRUE(fb.InWorkspace({x, y}));
    }
  }
  EXPECT_FALSE(fb.InWorkspace({0.0, 0.330}));
  EXPECT_FALSE(fb.InWorkspace({0.2, 0.2}));
  // J2 beyond 180° is reported in its own range (e.g. 213° at the left lower corner), not as −147°.
  Eigen::Vector2d q;
  ASSERT_TRUE(fb.Inverse({-0.190, 0.090}, q));
  EXPECT_GT(q.y(), 180.0 * kDeg);
}

TEST(FiveBar, JacobianMatchesCentralFiniteDifferences) {
  FiveBarConfig skew;
  skew.base_separation_m = 0.05;
  skew.distal_1_m = 0.22;
  for (const FiveBarConfig& c : {FiveBarConfig{}, skew}) {
    const FiveBar fb{c};
    for (double t1 = -30.0; t1 <= 100.0; t1 += 13.0) {
      for (double t2 = 80.0; t2 <= 210.0; t2 += 13.0) {
        const Eigen::Vector2d q{t1 * kDeg, t2 * kDeg};
        Eigen::Matrix2d jac;
        if (!fb.Jacobian(q, jac) || fb.Margin(q).min < 0.1) continue;
        const double h = 1e-6;
        for (int j = 0; j < 2; ++j) {
          Eigen::Vector2d dq = Eigen::Vector2d::Zero();
          dq(j) = h;
          Eigen::Vector2d pp;
          Eigen::Vector2d pm;
          ASSERT_TRUE(fb.Forward(q + dq, pp) && fb.Forward(q - dq, pm));
          const Eigen::Vector2d fd = (pp - pm) / (2.0 * h);
          EXPECT_NEAR(jac(0, j), fd.x(), 1e-6);
          EXPECT_NEAR(jac(1, j), fd.y(), 1e-6);
        }
      }
    }
  }
}

TEST(FiveBar, SingularityMarginGoesToZeroWhenStretchedAndIsLargeInside) {
  const FiveBar fb{FiveBarConfig{}};
  // Rhombus nearly closed (Δ → 0): distal links parallel, handle near 400 mm.
  EXPECT_LT(fb.Margin({89.5 * kDeg, 90.5 * kDeg}).parallel, 0.02);
  const SingularityMargin inside = fb.Margin({45.0 * kDeg, 135.0 * kDeg});
  EXPECT_NEAR(inside.parallel, 1.0, 1e-9);  // Δ = 90°: distal links perpendicular.
  EXPECT_GT(inside.min, 0.7);
}

TEST(FiveBar, BadGeometryIsRejectedAtSetUp) {
  FiveBarConfig c;
  c.distal_1_m = 0.0;
  EXPECT_THROW(FiveBar{c}, Error);
  c = FiveBarConfig{};
  c.joint_2_min_rad = c.joint_2_max_rad;
  EXPECT_THROW(FiveBar{c}, Error);
  c = FiveBarConfig{};
  c.workspace_x_min_m = std::nan("");
  EXPECT_THROW(FiveBar{c}, Error);
  const FiveBar fb{FiveBarConfig{}};
  Eigen::Vector2d p;
  EXPECT_FALSE(fb.Forward({std::nan(""), 0.0}, p));
  EXPECT_FALSE(fb.Inverse({0.0, 0.5}, p));  // beyond reach
}

}  // namespace
}  // namespace teleop::device::hybrid
