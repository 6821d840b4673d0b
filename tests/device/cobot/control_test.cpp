// Closed-loop behaviour of the cobot controllers on the simulated rig, in physical units:
//  - virtual caster: apparent lateral mass = 1/K₁ above the speed floor ε, growing as ε/(K₁|u|) below it (eq 2);
//  - constraint tracking converges for u·τ < L and does not for u·τ > L (eq 11);
//  - virtual wall: the overlay reduces the penetration of a Fig. 9 wall strike; the wall releases when the operator
//    pulls away, and holds while pushed.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "device/cobot/scripted_operator.hpp"
#include "device/cobot/unicycle_cobot.hpp"
#include "device/cobot/virtual_caster.hpp"

namespace teleop::device::cobot {
namespace {

constexpr double kPeriod_s = 0.001;
constexpr double kDeg = std::numbers::pi / 180.0;

TEST(CobotCaster, Eq2TorqueByHand) {
  VirtualCasterConfig c;
  c.k1_per_kg = 0.1;
  c.k2_Nms_per_rad = 0.5;
  c.speed_floor_m_per_s = 0.02;
  // Heading +x, 3 N to the left, u = 0.2 m/s, ω = 0.5 rad/s: Γ = 0.5·(0.1·3/0.2 − 0.5) = 0.5 N·m.
  CasterOutput out = VirtualCasterStep(c, 0.0, 3.0, 0.0, 0.2, 0.5);
  EXPECT_NEAR(out.lateral_force_N, 3.0, 1e-12);
  EXPECT_NEAR(out.steering_torque_Nm, 0.5, 1e-12);
  // Backwards: the sign of u flips the steering direction (eq 1's sign product).
  out = VirtualCasterStep(c, 0.0, 3.0, 0.0, -0.2, 0.0);
  EXPECT_NEAR(out.commanded_rate_rad_per_s, -1.5, 1e-12);
  // Below the floor, the denominator is ε.
  out = VirtualCasterStep(c, 0.0, 3.0, 0.0, 0.001, 0.0);
  EXPECT_NEAR(out.commanded_rate_rad_per_s, 0.1 * 3.0 / 0.02, 1e-12);
  out = VirtualCasterStep(c, 0.0, 3.0, 0.0, 0.0, 0.0);  // u = 0: sign(0) = +1, finite
  EXPECT_NEAR(out.commanded_rate_rad_per_s, 15.0, 1e-12);
}

double ApparentLateralMass_kg(double speed_m_per_s) {
  const UnicycleCobotConfig config = UnicycleCobotConfig::Prototype();
  UnicyclePlantState initial;
  initial.speed_m_per_s = speed_m_per_s;
  UnicycleCobot cobot(config, Constraint::Line({0.0, 1e3}, {1.0, 0.0}, true), initial);
  cobot.controller().SetWallActive(false);
  TurningOperatorConfig op_config;
  op_config.speed_m_per_s = speed_m_per_s;
  op_config.lateral_acceleration_m_per_s2 = 0.05;
  TurningOperator op(op_config);
  double force = 0.0;
  double accel = 0.0;
  for (int k = 0; k < 8000; ++k) {
    const CobotSample s = cobot.Step(op.Step(cobot.state(), kPeriod_s), kPeriod_s);
    if (k >= 4000) {
      force += s.lateral_force_N;
      accel += s.lateral_acceleration_m_per_s2;
    }
  }
  return force / accel;
}

TEST(CobotCaster, ApparentLateralMassIsTheVirtualMassAboveTheSpeedFloor) {
  const double virtual_mass = 1.0 / UnicycleCobotConfig::Prototype().controller.caster.k1_per_kg;  // 10 kg
  for (const double speed : {0.05, 0.2, 0.4}) {
    EXPECT_NEAR(ApparentLateralMass_kg(speed), virtual_mass, 0.03 * virtual_mass) << speed << " m/s";
  }
}

TEST(CobotCaster, ApparentLateralMassGrowsBelowTheSpeedFloor) {
  const UnicycleCobotConfig config = UnicycleCobotConfig::Prototype();
  const double virtual_mass = 1.0 / config.controller.caster.k1_per_kg;
  const double floor = config.controller.caster.speed_floor_m_per_s;  // 0.02 m/s
  double previous = 0.0;
  for (const double speed : {0.015, 0.01, 0.005}) {
    const double mass = ApparentLateralMass_kg(speed);
    EXPECT_NEAR(mass, virtual_mass * floor / speed, 0.05 * virtual_mass * floor / speed) << speed << " m/s";
    EXPECT_GT(mass, previous);
    previous = mass;
  }
}

/// Bilateral line tracking from a 2 mm offset at constant u; returns max |p| over the last quarter (m).
double LateOffset_m(double speed_m_per_s, double tau_s, double lookahead_m) {
  UnicycleCobotConfig c = UnicycleCobotConfig::Prototype();
  c.plant.steering_damping_Nms_per_rad = 0.0;
  c.plant.cornering_stiffness_N_per_rad = 0.0;
  c.plant.max_steering_torque_Nm = 50.0;
  const double k2 = SteeringGainFor(c.plant, tau_s);
  c.controller.caster.k2_Nms_per_rad = k2;
  c.controller.tracker.k2_Nms_per_rad = k2;
  c.controller.tracker.lookahead_m = lookahead_m;
  c.controller.tracker.max_curvature_per_m = 1e4;
  c.controller.overlay_enabled = false;
  c.controller.release_distance_m = 10.0;
  c.controller.release_force_N = 1e6;
  c.steering_rate_filter.cutoff_hz = 300.0;
  const Constraint wall = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true);
  UnicyclePlantState initial;
  initial.position_m = {0.0, 0.002};
  initial.speed_m_per_s = speed_m_per_s;
  UnicycleCobot cobot(c, wall, initial);
  PushingOperatorConfig op_config;
  op_config.speed_m_per_s = speed_m_per_s;
  op_config.push_angle_rad = 0.0;
  op_config.max_force_N = 500.0;
  PushingOperator op(op_config, wall);
  const int steps = static_cast<int>(60.0 * lookahead_m / speed_m_per_s / kPeriod_s);
  double late = 0.0;
  for (int k = 0; k < steps; ++k) {
    const CobotSample s = cobot.Step(op.Step(cobot.state(), kPeriod_s), kPeriod_s);
    const double p = std::abs(wall.Evaluate(s.position_m).penetration_m);
    if (!std::isfinite(p) || p > 0.2) return std::numeric_limits<double>::infinity();
    if (k >= 3 * steps / 4) late = std::max(late, p);
  }
  return late;
}

TEST(CobotTracking, ConvergesBelowTheEq11BoundAndNotAbove) {
  const double tau = 0.1;
  const double lookahead = 0.02;                              // u_max = L/τ = 0.2 m/s
  EXPECT_LT(LateOffset_m(0.5 * 0.2, tau, lookahead), 1e-4);   // 2 mm → < 0.1 mm
  EXPECT_LT(LateOffset_m(0.85 * 0.2, tau, lookahead), 1e-3);  // slower, still converging
  EXPECT_GT(LateOffset_m(1.3 * 0.2, tau, lookahead), 2e-3);   // grows beyond the initial offset
}

struct StrikeResult {
  double max_penetration_m = 0.0;
  double final_penetration_m = 0.0;
  WallMode final_mode = WallMode::kCaster;
};

StrikeResult Strike(bool overlay, double integral_gain = 0.0) {
  UnicycleCobotConfig c = UnicycleCobotConfig::Prototype();
  c.controller.overlay_enabled = overlay;
  c.controller.tracker.integral_gain_per_m3 = integral_gain;
  const Constraint wall = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true);
  UnicyclePlantState initial;
  initial.position_m = {0.0, -0.15};
  initial.heading_rad = 60.0 * kDeg;
  initial.speed_m_per_s = 0.3;
  UnicycleCobot cobot(c, wall, initial);
  PushingOperatorConfig op_config;
  op_config.speed_m_per_s = 0.3;
  op_config.push_angle_rad = 60.0 * kDeg;
  PushingOperator op(op_config, wall);
  StrikeResult r;
  for (int k = 0; k < 3000; ++k) {
    const CobotSample s = cobot.Step(op.Step(cobot.state(), kPeriod_s), kPeriod_s);
    r.max_penetration_m = std::max(r.max_penetration_m, s.control.penetration_m);
    r.final_penetration_m = s.control.penetration_m;
    r.final_mode = s.control.mode;
  }
  return r;
}

TEST(CobotWall, OverlayReducesPenetrationInTheFig9Strike) {
  const StrikeResult without = Strike(false);
  const StrikeResult with = Strike(true);
  EXPECT_GT(without.max_penetration_m, 0.01);  // a 60° strike at 0.3 m/s: the 60° turn takes a while
  EXPECT_LT(with.max_penetration_m, 0.3 * without.max_penetration_m);
  // Both end up on the wall, held against the operator's push.
  EXPECT_EQ(without.final_mode, WallMode::kTracking);
  EXPECT_EQ(with.final_mode, WallMode::kTracking);
  EXPECT_LT(std::abs(with.final_penetration_m), 0.002);
}

TEST(CobotWall, IntegralActionRemovesTheSlipError) {
  const double plain = Strike(true).final_penetration_m;
  const double integral = Strike(true, 0.5 / std::pow(0.05, 3)).final_penetration_m;
  EXPECT_GT(plain, 5e-4);  // slip under a 7 N push into the wall: ~1 mm
  EXPECT_LT(std::abs(integral), 0.3 * plain);
}

TEST(CobotWall, ReleasesWhenTheForcePointsAwayAndHoldsWhilePushed) {
  const Constraint wall = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true);  // wall y > 0
  UnicyclePlantState initial;
  initial.position_m = {0.0, 0.0005};  // just inside: the controller engages at once
  initial.speed_m_per_s = 0.2;
  UnicycleCobot cobot(UnicycleCobotConfig::Prototype(), wall, initial);
  // Push along the wall and into it for 1 s: it holds (tracking, p small).
  for (int k = 0; k < 1000; ++k) {
    const CobotSample s = cobot.Step({5.0, 3.0}, kPeriod_s);
    ASSERT_NE(s.control.mode, WallMode::kCaster) << "released while pushed, at " << k;
  }
  EXPECT_LT(std::abs(cobot.controller().wall().Evaluate(cobot.state().position_m).penetration_m), 0.003);
  // Pull away from the wall (−y): back to the caster at once, and the cart leaves the wall.
  const CobotSample first = cobot.Step({5.0, -3.0}, kPeriod_s);
  EXPECT_EQ(first.control.mode, WallMode::kCaster);
  EXPECT_EQ(cobot.controller().release_count(), 1);
  for (int k = 0; k < 1000; ++k) (void)cobot.Step({5.0, -3.0}, kPeriod_s);
  EXPECT_LT(cobot.controller().wall().Evaluate(cobot.state().position_m).penetration_m, -0.02);
}

TEST(CobotWall, LockedSteeringKeepsTheCurrentTangent) {
  // The fault reaction: with the steering locked the cart keeps rolling straight along its heading (the wheel
  // is not turned into the wall), and the brake stops it where the rig has one.
  UnicycleCobotConfig c = UnicycleCobotConfig::Prototype();
  c.plant.cornering_stiffness_N_per_rad = 0.0;
  c.plant.brake_max_force_N = 30.0;
  UnicyclePlantState initial;
  initial.heading_rad = 0.2;
  initial.speed_m_per_s = 0.2;
  UnicycleCobot cobot(c, Constraint::Line({0.0, 1.0}, {1.0, 0.0}, true), initial);
  cobot.SetLocked(true);
  for (int k = 0; k < 2000; ++k) (void)cobot.Step({2.0, 8.0}, kPeriod_s);  // a sideways push tries to turn it
  EXPECT_NEAR(cobot.state().heading_rad, 0.2, 0.01);
  EXPECT_EQ(cobot.state().speed_m_per_s, 0.0);
}

}  // namespace
}  // namespace teleop::device::cobot
