// Constraint geometry (Colgate et al. Fig. 5): penetration, normals, tangents and curvature of lines, circles and
// polylines; tracking errors p and θ; eq 7/8 gains.
#include "device/cobot/constraint.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>

#include "device/cobot/constraint_tracker.hpp"
#include "teleop/error.hpp"

namespace teleop::device::cobot {
namespace {

constexpr double kTol = 1e-12;

TEST(CobotConstraint, LineSignedPenetrationAndNormal) {
  // Wall y > 0 (forbidden to the left of +x).
  const Constraint wall = Constraint::Line({0.0, 0.0}, {2.0, 0.0}, true);
  ConstraintSample s = wall.Evaluate({0.3, -0.02});
  EXPECT_NEAR(s.penetration_m, -0.02, kTol);
  EXPECT_NEAR(s.normal_in.y(), 1.0, kTol);
  EXPECT_NEAR(s.closest_m.x(), 0.3, kTol);
  EXPECT_NEAR(s.closest_m.y(), 0.0, kTol);
  EXPECT_NEAR(s.curvature_away_per_m, 0.0, kTol);
  s = wall.Evaluate({-1.0, 0.005});
  EXPECT_NEAR(s.penetration_m, 0.005, kTol);
  // Same line, forbidden on the right: the sign flips.
  const Constraint right = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, false);
  EXPECT_NEAR(right.Evaluate({0.3, -0.02}).penetration_m, 0.02, kTol);
}

TEST(CobotConstraint, CircleInsideAndOutside) {
  const Constraint keep_in = Constraint::Circle({1.0, 1.0}, 0.3, true);
  ConstraintSample s = keep_in.Evaluate({1.0, 1.0 - 0.25});
  EXPECT_NEAR(s.penetration_m, -0.05, kTol);
  EXPECT_NEAR(s.normal_in.y(), -1.0, kTol);  // outward at the bottom
  EXPECT_NEAR(s.closest_m.y(), 0.7, kTol);
  EXPECT_NEAR(s.curvature_away_per_m, 1.0 / 0.3, kTol);  // bends towards the centre, away from the wall
  const Constraint obstacle = Constraint::Circle({0.0, 0.0}, 0.2, false);
  s = obstacle.Evaluate({0.0, 0.15});
  EXPECT_NEAR(s.penetration_m, 0.05, kTol);
  EXPECT_NEAR(s.normal_in.y(), -1.0, kTol);
  EXPECT_NEAR(s.curvature_away_per_m, -5.0, kTol);  // convex obstacle bends towards the forbidden side
  // At the centre (degenerate direction) the result is still finite.
  EXPECT_TRUE(keep_in.Evaluate({1.0, 1.0}).normal_in.allFinite());
}

TEST(CobotConstraint, PolylineSegmentsVerticesAndRays) {
  // An L-shaped wall: along +x to (1, 0), then up to (1, 1); forbidden on the left (inside the corner's +y side).
  const std::array<Vec2, 3> points{Vec2(0.0, 0.0), Vec2(1.0, 0.0), Vec2(1.0, 1.0)};
  const Constraint wall = Constraint::Polyline(points, true);
  EXPECT_NEAR(wall.Evaluate({0.5, -0.1}).penetration_m, -0.1, kTol);  // first segment, outside
  EXPECT_NEAR(wall.Evaluate({0.5, 0.05}).penetration_m, 0.05, kTol);  // inside, nearer the first segment
  EXPECT_NEAR(wall.Evaluate({1.2, 0.5}).penetration_m, -0.2, kTol);   // second segment, outside
  // Outside the convex corner: the nearest feature is the vertex, distance √2·0.1.
  const ConstraintSample corner = wall.Evaluate({1.1, -0.1});
  EXPECT_NEAR(corner.penetration_m, -std::sqrt(0.02), 1e-12);
  EXPECT_NEAR(corner.closest_m.x(), 1.0, kTol);
  // The first segment extends backwards as a ray.
  EXPECT_NEAR(wall.Evaluate({-5.0, -0.3}).penetration_m, -0.3, kTol);
}

TEST(CobotConstraint, BadGeometryIsRejectedAtSetUp) {
  EXPECT_THROW(Constraint::Line({0.0, 0.0}, {0.0, 0.0}, true), Error);
  EXPECT_THROW(Constraint::Circle({0.0, 0.0}, 0.0, true), Error);
  EXPECT_THROW(Constraint::Circle({0.0, NAN}, 1.0, true), Error);
  const std::array<Vec2, 1> one{Vec2(0.0, 0.0)};
  EXPECT_THROW(Constraint::Polyline(one, true), Error);
  const std::array<Vec2, 2> same{Vec2(1.0, 0.0), Vec2(1.0, 0.0)};
  EXPECT_THROW(Constraint::Polyline(same, true), Error);
  Constraint c = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true);
  EXPECT_FALSE(Constraint::TryCircle({0.0, 0.0}, -1.0, true, c));
  EXPECT_EQ(c.kind(), Constraint::Kind::kLine);
}

TEST(CobotTracking, PenetrationAndOutOfTangencySigns) {
  const Constraint wall = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true);
  const ConstraintSample s = wall.Evaluate({0.0, -0.01});
  // Moving at +20° (towards the wall y > 0): θ = +20°, turning away is clockwise.
  TrackingErrors e = ComputeTrackingErrors(s, 20.0 * std::numbers::pi / 180.0);
  EXPECT_NEAR(e.theta_rad, 20.0 * std::numbers::pi / 180.0, 1e-12);
  EXPECT_EQ(e.away_sign, -1.0);
  EXPECT_NEAR(e.penetration_m, -0.01, kTol);
  // Moving the other way along the wall at 160° (towards it): also θ = +20°, away is now counter-clockwise.
  e = ComputeTrackingErrors(s, 160.0 * std::numbers::pi / 180.0);
  EXPECT_NEAR(e.theta_rad, 20.0 * std::numbers::pi / 180.0, 1e-12);
  EXPECT_EQ(e.away_sign, 1.0);
}

TEST(CobotTracking, Eq7GainsTendToEq8AndGiveRhoTanPhi) {
  const double lookahead = 0.05;
  const TrackingGains small = ComputeTrackingGains(ConstraintTrackerConfig::GainForm::kSmallAngle, lookahead, 0.0);
  EXPECT_NEAR(small.p_per_m2, 2.0 / (lookahead * lookahead), 1e-9);
  EXPECT_NEAR(small.theta_per_m, 2.0 / lookahead, 1e-9);
  // ρ = 10 m ≫ L: eq 7 within 0.1 % of eq 8.
  const TrackingGains far = ComputeTrackingGains(ConstraintTrackerConfig::GainForm::kCircular, lookahead, 0.1);
  EXPECT_NEAR(far.p_per_m2 / small.p_per_m2, 1.0, 1e-3);
  EXPECT_NEAR(far.theta_per_m / small.theta_per_m, 1.0, 1e-3);
  // ρ = 0.1 m: b/a = ρ·tan φ with φ = L/ρ (the bound of eq 10).
  const double rho = 0.1;
  const TrackingGains near = ComputeTrackingGains(ConstraintTrackerConfig::GainForm::kCircular, lookahead, 1.0 / rho);
  EXPECT_NEAR(near.theta_per_m / near.p_per_m2, rho * std::tan(lookahead / rho), 1e-12);
  // Symmetric in the sign of the curvature.
  const TrackingGains neg = ComputeTrackingGains(ConstraintTrackerConfig::GainForm::kCircular, lookahead, -1.0 / rho);
  EXPECT_NEAR(neg.p_per_m2, near.p_per_m2, 1e-9);
}

}  // namespace
}  // namespace teleop::device::cobot
