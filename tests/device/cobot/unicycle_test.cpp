// The unicycle cobot plant: rolling without slip, the slip model, intrinsic passivity of steering, sensors and
// estimators; the real-time steps do not allocate.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "device/cobot/cobot_sensors.hpp"
#include "device/cobot/rate_estimator.hpp"
#include "device/cobot/unicycle_cobot.hpp"
#include "device/cobot/unicycle_plant.hpp"
#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::device::cobot {
namespace {

constexpr double kPeriod_s = 0.001;

TEST(CobotUnicycle, RollsAlongItsHeadingOnly) {
  UnicyclePlantConfig c;
  UnicyclePlantState s;
  s.heading_rad = 0.3;
  s.speed_m_per_s = 0.2;
  UnicyclePlantInput in;
  in.handle_force_N = {0.0, 50.0};  // a hard sideways push: no lateral motion without slip
  for (int k = 0; k < 1000; ++k) Step(c, in, kPeriod_s, s);
  const Vec2 heading = UnitAt(0.3);
  EXPECT_NEAR(Cross(heading, s.position_m), 0.0, 1e-12);  // still on the line of the heading
  EXPECT_GT(s.position_m.dot(heading), 0.0);
}

TEST(CobotUnicycle, ConstantSteeringRateDrawsACircleOfRadiusUOverOmega) {
  UnicyclePlantConfig c;
  c.rolling_damping_Ns_per_m = 0.0;
  c.steering_damping_Nms_per_rad = 0.0;
  UnicyclePlantState s;
  s.speed_m_per_s = 0.2;
  s.steering_rate_rad_per_s = 1.0;                                         // no torque, no damping: ω stays
  const int steps = static_cast<int>(2.0 * std::numbers::pi / kPeriod_s);  // one turn
  double max_radius_error = 0.0;
  for (int k = 0; k < steps; ++k) {
    Step(c, {}, kPeriod_s, s);
    max_radius_error = std::max(max_radius_error, std::abs((s.position_m - Vec2(0.0, 0.2)).norm() - 0.2));
  }
  EXPECT_LT(max_radius_error, 2e-4);  // first-order integration over one turn: 0.1 % of the radius
  EXPECT_LT(s.position_m.norm(), 1e-3);
}

TEST(CobotUnicycle, SlipVelocityFollowsTheLateralLoad) {
  UnicyclePlantConfig c;
  c.cornering_stiffness_N_per_rad = 500.0;
  UnicyclePlantState s;
  s.speed_m_per_s = 0.2;
  UnicyclePlantInput in;
  in.handle_force_N = {4.0, 5.0};  // 5 N across the wheel, heading +x
  Step(c, in, kPeriod_s, s);
  EXPECT_NEAR(s.slip_velocity_m_per_s, std::abs(s.speed_m_per_s) * 5.0 / 500.0, 1e-9);
}

// Rolling backwards the wheel still gives way to the push, never against it: a passive device never pushes the
// hand. The slip velocity has the sign of the lateral load whichever way the wheel rolls (|u|·F⊥/C), so the hand's
// force does non-negative work through it. (Slip ∝ u instead of |u| would move the cart into a backwards-rolling
// operator's hand: −0.2 mm/s against a 5 N push.)
TEST(CobotUnicycle, SlipGivesWayToThePushRollingEitherWay) {
  UnicyclePlantConfig c;
  c.cornering_stiffness_N_per_rad = 500.0;
  for (const double speed : {0.2, -0.2}) {
    for (const double push : {5.0, -5.0}) {
      UnicyclePlantState s;
      s.speed_m_per_s = speed;
      UnicyclePlantInput in;
      in.handle_force_N = {0.0, push};  // across the wheel, heading +x
      Step(c, in, kPeriod_s, s);
      EXPECT_NEAR(s.slip_velocity_m_per_s, std::abs(s.speed_m_per_s) * push / 500.0, 1e-9)
          << "u " << speed << " push " << push;
      EXPECT_GT(push * s.slip_velocity_m_per_s, 0.0) << "u " << speed << " push " << push;  // the hand does work
    }
  }
}

// The point of a cobot (§2): the steering motor turns the wheel about its contact point and cannot push the
// operator. With no operator force, any steering torque sequence leaves the cart's kinetic energy non-increasing.
TEST(CobotUnicycle, SteeringIsPassiveInThePlane) {
  UnicyclePlantConfig c;
  c.rolling_damping_Ns_per_m = 0.0;
  c.max_steering_torque_Nm = 5.0;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> torque(-5.0, 5.0);
  UnicyclePlantState s;
  s.speed_m_per_s = 0.3;
  const double energy0 = 0.5 * c.cart_mass_kg * s.speed_m_per_s * s.speed_m_per_s;
  for (int k = 0; k < 5000; ++k) {
    UnicyclePlantInput in;
    in.steering_torque_Nm = torque(rng);
    Step(c, in, kPeriod_s, s);
    ASSERT_LE(0.5 * c.cart_mass_kg * s.speed_m_per_s * s.speed_m_per_s, energy0 * (1.0 + 1e-12));
  }
}

TEST(CobotUnicycle, BrakeStopsWithoutReversing) {
  UnicyclePlantConfig c;
  c.brake_max_force_N = 20.0;
  UnicyclePlantState s;
  s.speed_m_per_s = 0.2;
  UnicyclePlantInput in;
  in.brake_command = 1.0;
  for (int k = 0; k < 1000; ++k) Step(c, in, kPeriod_s, s);
  EXPECT_EQ(s.speed_m_per_s, 0.0);
}

TEST(CobotUnicycle, NonFiniteInputsKeepTheStateFinite) {
  UnicyclePlantConfig c;
  UnicyclePlantState s;
  UnicyclePlantInput in;
  in.handle_force_N = {NAN, 1.0};
  in.steering_torque_Nm = std::numeric_limits<double>::infinity();
  in.brake_command = std::nan("");
  Step(c, in, kPeriod_s, s);
  EXPECT_TRUE(s.position_m.allFinite());
  EXPECT_TRUE(std::isfinite(s.heading_rad));
  EXPECT_TRUE(std::isfinite(s.steering_rate_rad_per_s));
}

TEST(CobotUnicycle, BadConfigurationsAreRejected) {
  UnicyclePlantConfig c;
  c.cart_mass_kg = 0.0;
  EXPECT_THROW(Validate(c), Error);
  c = {};
  c.steering_inertia_kgm2 = std::nan("");
  EXPECT_THROW(Validate(c), Error);
  CobotSensorConfig sensors;
  sensors.wheel_radius_m = -1.0;
  EXPECT_THROW(Validate(sensors), Error);
  EXPECT_THROW((void)SteeringGainFor(UnicyclePlantConfig{}, 0.0), Error);
  UnicyclePlantConfig slow;
  slow.steering_damping_Nms_per_rad = 1.0;  // open loop τ = J/b = 2 ms: a 20 ms closed loop is unreachable
  EXPECT_THROW((void)SteeringGainFor(slow, 0.02), Error);
}

TEST(CobotSensors, EncoderResolutionQuantizesTheReadings) {
  CobotSensorConfig c;
  c.steering_encoder_counts_per_rev = 4096;
  c.wheel_encoder_counts_per_rev = 1000;
  c.position_resolution_m = 1e-3;
  const CobotMeasurement m = Measure(c, {0.01234, -0.0006}, 0.001, 0.0, {1.234, 0.0});
  EXPECT_NEAR(m.position_m.x(), 0.012, 1e-15);
  EXPECT_NEAR(m.position_m.y(), -0.001, 1e-15);
  const double count = 2.0 * std::numbers::pi / 4096.0;
  EXPECT_NEAR(m.steering_angle_rad, count, 1e-15);  // 0.001 rad rounds to one count (1.53 mrad)
  EXPECT_NEAR(m.handle_force_N.x(), 1.23, 1e-12);
}

TEST(CobotSensors, RateEstimatorConvergesToTheTrueRate) {
  RateEstimator est({50.0});
  est.Reset(0.0);
  double angle = 0.0;
  double mean = 0.0;
  for (int k = 0; k < 1000; ++k) {
    angle += 2.0 * kPeriod_s;
    const double rate = est.Step(Quantize(angle, 2.0 * std::numbers::pi / 16384.0), kPeriod_s);
    if (k >= 500) {
      mean += rate / 500.0;
      EXPECT_NEAR(rate, 2.0, 0.15);  // quantization noise after the filter: one count/ms is 0.38 rad/s
    }
  }
  EXPECT_NEAR(mean, 2.0, 0.01);
  // Wrapped angles (steering) are differenced on the circle.
  RateEstimator wrap({0.0});
  wrap.Reset(std::numbers::pi - 0.001);
  EXPECT_NEAR(wrap.Step(-std::numbers::pi + 0.001, kPeriod_s), 2.0, 1e-9);
}

TEST(CobotUnicycle, RigStepDoesNotAllocate) {
  UnicycleCobot cobot(UnicycleCobotConfig::Prototype(), Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true));
  (void)cobot.Step({1.0, 0.0}, kPeriod_s);
  test::AllocationCounter counter;
  for (int k = 0; k < 200; ++k) (void)cobot.Step({1.0, 0.5}, kPeriod_s);
  EXPECT_EQ(counter.count(), 0u);
}

}  // namespace
}  // namespace teleop::device::cobot
