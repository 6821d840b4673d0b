#include <gtest/gtest.h>

#include <cmath>

#include "device/hybrid/handle_force_sensor.hpp"
#include "device/hybrid/motor_model.hpp"
#include "device/hybrid/particle_brake.hpp"
#include "teleop/error.hpp"

namespace teleop::device::hybrid {
namespace {

// First-order current-loop lag: after one time constant (0.5 ms by default; the paper's 7 ms is the motor's
// mechanical time constant, motor_model.hpp) 1 − e⁻¹ = 63.2 % of a step (1 µs steps, tolerance 0.1 %).
TEST(MotorModel, HalfMillisecondCurrentLoopLagAndSaturationAtTheJoint) {
  MotorModel m{MotorConfig{}};
  EXPECT_EQ(MotorConfig{}.time_constant_s, 0.0005);
  double tau = 0.0;
  for (int i = 0; i < 500; ++i) tau = m.Step(10.0, 1e-6);
  EXPECT_NEAR(tau / 10.0, 1.0 - std::exp(-1.0), 1e-3);
  for (int i = 0; i < 300000; ++i) tau = m.Step(1000.0, 1e-6);
  EXPECT_NEAR(tau, 4.44 * 5.0, 1e-6);  // 4.44 N·m after the reducer × 5:1 pulleys
  EXPECT_NEAR(m.Step(std::nan(""), 1.0), 0.0, 1e-9);
  MotorConfig bad;
  bad.pulley_ratio = 0.0;
  EXPECT_THROW(MotorModel{bad}, Error);
}

TEST(ParticleBrake, FiftyMillisecondLagDragAndRange) {
  BrakeConfig cfg;
  cfg.residual_fraction = 0.0;
  ParticleBrake b{cfg};
  EXPECT_NEAR(b.capacity_joint_Nm(), 0.08 * 5.0, 1e-12);  // unpowered drag, at the joint
  double c = 0.0;
  for (int i = 0; i < 50; ++i) c = b.Step(4.0, 1e-3);
  EXPECT_NEAR(b.delivered_shaft_Nm() / 4.0, 1.0 - std::exp(-1.0), 1e-9);
  for (int i = 0; i < 2000; ++i) c = b.Step(10.0, 1e-3);  // clamped to 4 N·m
  EXPECT_NEAR(c, (4.0 + 0.08) * 5.0, 1e-6);
  for (int i = 0; i < 2000; ++i) c = b.Step(-3.0, 1e-3);  // a brake has no negative torque
  EXPECT_NEAR(c, 0.4, 1e-6);
}

// Remanence: after a full 4 N·m and a release, 2 % of it remains on top of the 0.08 N·m drag.
TEST(ParticleBrake, ResidualTorqueAfterRelease) {
  ParticleBrake b{BrakeConfig{}};
  for (int i = 0; i < 2000; ++i) (void)b.Step(4.0, 1e-3);
  double c = 0.0;
  for (int i = 0; i < 2000; ++i) c = b.Step(0.0, 1e-3);
  EXPECT_NEAR(c, (0.08 + 0.02 * 4.0) * 5.0, 1e-6);
  b.Reset();
  EXPECT_NEAR(b.capacity_joint_Nm(), 0.08 * 5.0, 1e-12);
  BrakeConfig bad;
  bad.static_ratio = 0.9;
  EXPECT_THROW(bad.Validate(), Error);
}

// Play hysteresis of width h: on the way down the delivered torque stays h/2 above the (settled) command.
TEST(ParticleBrake, HysteresisHoldsOnReversal) {
  BrakeConfig cfg;
  cfg.hysteresis_Nm = 0.4;
  cfg.time_constant_s = 0.0;
  ParticleBrake b{cfg};
  (void)b.Step(2.0, 1e-3);
  EXPECT_NEAR(b.delivered_shaft_Nm(), 1.8, 1e-12);
  (void)b.Step(1.9, 1e-3);  // within the band: no change
  EXPECT_NEAR(b.delivered_shaft_Nm(), 1.8, 1e-12);
  (void)b.Step(1.0, 1e-3);
  EXPECT_NEAR(b.delivered_shaft_Nm(), 1.2, 1e-12);
}

TEST(HandleForceSensor, BiasResolutionAndNaN) {
  HandleForceSensorConfig cfg;
  cfg.bias_N = {0.5, -0.5};
  cfg.resolution_N = 0.25;
  const Eigen::Vector2d m = MeasureHandleForce(cfg, {1.0, 2.0});
  EXPECT_DOUBLE_EQ(m.x(), 1.5);
  EXPECT_DOUBLE_EQ(m.y(), 1.5);
  EXPECT_FALSE(MeasureHandleForce(cfg, {std::nan(""), 0.0}).allFinite());
  cfg.resolution_N = -1.0;
  EXPECT_THROW(cfg.Validate(), Error);
}

}  // namespace
}  // namespace teleop::device::hybrid
