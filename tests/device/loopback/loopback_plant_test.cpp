#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "teleop/device/loopback.hpp"
#include "teleop/error.hpp"

namespace teleop::device {
namespace {

using Kind = OperatorSegment::Kind;

DofVector One(double x) { return DofVector::Constant(1, x); }

TEST(LoopbackPlant, FreeMassDamperMatchesTheAnalyticStepResponse) {
  // m·ẍ + b·ẋ = F from rest: v = F/b·(1 - e^{-t/τ}), x = F/b·(t - τ(1 - e^{-t/τ})), τ = m/b.
  const double m = 0.040, b = 0.41, force = 1.0, period_s = 0.001;
  LoopbackPlant plant(LoopbackPlantConfig::PaperMaster());
  plant.Write(Command::Force(One(force)));
  const double tau = m / b;
  for (int k = 1; k <= 2000; ++k) {
    plant.Update(period_s);
    const double t = k * period_s;
    const double e = std::exp(-t / tau);
    ASSERT_NEAR(plant.true_position_m()[0], force / b * (t - tau * (1.0 - e)), 1e-9) << "k = " << k;
    ASSERT_NEAR(plant.true_velocity_m_per_s()[0], force / b * (1.0 - e), 1e-9) << "k = " << k;
  }
  EXPECT_NEAR(plant.time_s(), 2.0, 1e-12);
}

TEST(LoopbackPlant, OperatorSpringOscillatorMatchesTheAnalyticResponse) {
  // Undamped device + operator spring: (m + m_h)ẍ + k_h·x = F_h* (step) → x = F/k·(1 - cos ωt).
  LoopbackPlantConfig config;
  config.mass_kg = 0.04;
  config.damping_Ns_per_m = 0.0;
  config.human.enabled = true;
  config.human.mass_kg = 0.01;
  config.human.stiffness_N_per_m = 200.0;
  config.human.segment_count = 1;
  config.human.segments[0] = {Kind::kStep, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0};
  LoopbackPlant plant(config);
  const double omega = std::sqrt(200.0 / 0.05);
  for (int k = 1; k <= 1000; ++k) {
    plant.Update(0.001);
    ASSERT_NEAR(plant.true_position_m()[0], 2.0 / 200.0 * (1.0 - std::cos(omega * k * 0.001)), 1e-9) << k;
  }
}

TEST(LoopbackPlant, DiscretisationIsTheExactExponential) {
  // Underdamped m ẍ + b ẋ + k x = u: compare with the closed form for x(h), v(h) from (x0, v0) and held u.
  const double m = 0.05, b = 0.3, k = 200.0, h = 0.002;
  const auto step = analysis::DiscretizeMassSpringDamper(m, b, k, h);  // what the plant integrates with
  const double alpha = b / (2 * m), wd = std::sqrt(k / m - alpha * alpha);
  // Homogeneous response from x0 = 1, v0 = 0 and from x0 = 0, v0 = 1.
  const double e = std::exp(-alpha * h), c = std::cos(wd * h), s = std::sin(wd * h);
  EXPECT_NEAR(step.phi(0, 0), e * (c + alpha / wd * s), 1e-13);
  EXPECT_NEAR(step.phi(0, 1), e * s / wd, 1e-13);
  EXPECT_NEAR(step.phi(1, 0), -e * (k / m) / wd * s, 1e-11);
  EXPECT_NEAR(step.phi(1, 1), e * (c - alpha / wd * s), 1e-13);
  // Held unit force from rest: x = (1 - φ00)/k.
  EXPECT_NEAR(step.gamma(0), (1.0 - step.phi(0, 0)) / k, 1e-15);
  EXPECT_NEAR(step.gamma(1), -step.phi(1, 0) / k, 1e-13);
}

TEST(LoopbackPlant, EncoderQuantization) {
  LoopbackPlantConfig config;
  config.encoder_resolution_m = 1e-4;
  config.initial_position_m = One(0.00123456);
  LoopbackPlant plant(config);
  Reading reading;
  plant.Read(reading);
  EXPECT_NEAR(reading.position_m[0], 0.0012, 1e-15);
  EXPECT_NEAR(plant.true_position_m()[0], 0.00123456, 1e-18);
  config.initial_position_m = One(-0.00126);
  LoopbackPlant negative(config);
  negative.Read(reading);
  EXPECT_NEAR(reading.position_m[0], -0.0013, 1e-15);
}

TEST(LoopbackPlant, OperatorEquilibriumAndSensedForce) {
  LoopbackPlantConfig config = LoopbackPlantConfig::PaperMaster();
  config.human.enabled = true;
  config.human.mass_kg = 0.01;
  config.human.damping_Ns_per_m = 2.0;
  config.human.stiffness_N_per_m = 200.0;
  config.human.segment_count = 1;
  config.human.segments[0] = {Kind::kStep, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0};
  LoopbackPlant plant(config);
  for (int k = 0; k < 3000; ++k) plant.Update(0.001);
  Reading reading;
  plant.Read(reading);
  EXPECT_NEAR(plant.true_position_m()[0], 2.0 / 200.0, 1e-9);  // F_h* = k_h·x at rest
  EXPECT_NEAR(reading.force_N[0], 0.0, 1e-7);                  // nothing resists: F_h = 0
  // The actuator resists with 1 N: k_h·x = F_h* - 1 and the operator feels F_h = 1 N.
  plant.Write(Command::Force(One(-1.0)));
  for (int k = 0; k < 3000; ++k) plant.Update(0.001);
  plant.Read(reading);
  EXPECT_NEAR(plant.true_position_m()[0], 1.0 / 200.0, 1e-9);
  EXPECT_NEAR(reading.force_N[0], 1.0, 1e-7);
  EXPECT_NEAR(plant.OperatorTargetForce()[0], 2.0, 1e-15);
}

TEST(LoopbackPlant, OperatorScriptSegments) {
  LoopbackPlantConfig config;
  config.dof = 2;
  config.human.enabled = true;
  config.human.segment_count = 5;
  // ramp 0→3 N over [0.5, 2), hold, ramp back to -1 N over [3, 4), hold open-ended; a sine on axis 1.
  config.human.segments[0] = {Kind::kRamp, 0.5, 1.5, 0.0, 3.0, 0.0, 0.0, 0.0, 0};
  config.human.segments[1] = {Kind::kHold, 2.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0};
  config.human.segments[2] = {Kind::kRamp, 3.0, 1.0, 3.0, -1.0, 0.0, 0.0, 0.0, 0};
  config.human.segments[3] = {Kind::kHold, 4.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0};
  config.human.segments[4] = {Kind::kSine, 1.0, 0.0, 0.0, 0.0, 0.5, 2.0, 1.0, 1};
  LoopbackPlant plant(config);
  auto at = [&](double t) {
    while (plant.time_s() < t - 1e-9) plant.Update(0.00025);
    return plant.OperatorTargetForce();
  };
  EXPECT_NEAR(at(0.25)[0], 0.0, 1e-12);
  EXPECT_NEAR(at(0.25)[1], 0.0, 1e-12);
  EXPECT_NEAR(at(1.125)[1], 1.0 + 0.5 * std::sin(2.0 * std::numbers::pi * 2.0 * 0.125), 1e-9);  // 1.5 N
  EXPECT_NEAR(at(1.25)[0], 1.5, 1e-9);
  EXPECT_NEAR(at(2.5)[0], 3.0, 1e-9);
  EXPECT_NEAR(at(3.5)[0], 1.0, 1e-9);
  EXPECT_NEAR(at(5.0)[0], -1.0, 1e-9);
  EXPECT_NEAR(at(9.0)[0], -1.0, 1e-9);
}

LoopbackPlantConfig WallSlave(double k_w, double b_w) {
  LoopbackPlantConfig config = LoopbackPlantConfig::PaperSlave();
  config.environment.kind = SimulatedEnvironmentConfig::Kind::kWall;
  config.environment.position_m = 0.01;
  config.environment.stiffness_N_per_m = k_w;
  config.environment.damping_Ns_per_m = b_w;
  return config;
}

TEST(LoopbackPlant, WallContactForceAtRest) {
  LoopbackPlant plant(WallSlave(2000.0, 1.0));
  plant.Write(Command::Force(One(4.0)));  // the slave actuator pushes 4 N into the wall
  for (int k = 0; k < 3000; ++k) plant.Update(0.001);
  Reading reading;
  plant.Read(reading);
  EXPECT_NEAR(plant.true_position_m()[0], 0.01 + 4.0 / 2000.0, 1e-9);
  EXPECT_NEAR(reading.force_N[0], 4.0, 1e-6);  // F_e of eq. 4: the slave pushes its environment with 4 N
}

TEST(LoopbackPlant, WallOnlyPushes) {
  LoopbackPlantConfig config = WallSlave(2000.0, 1.0);
  config.initial_position_m = One(0.0105);
  config.initial_velocity_m_per_s = One(-2.0);  // k·d + b·v = 1 - 2 < 0: leaving faster than the wall relaxes
  LoopbackPlant plant(config);
  Reading reading;
  plant.Read(reading);
  EXPECT_EQ(reading.force_N[0], 0.0);
  // Free space slave reports no force at all.
  LoopbackPlant free_plant(LoopbackPlantConfig::PaperSlave());
  free_plant.Read(reading);
  EXPECT_EQ(reading.force_N[0], 0.0);
}

TEST(LoopbackPlant, ElasticBounceKeepsItsSpeedAndSubstepsConverge) {
  // An undamped slave hits an undamped 5000 N/m wall at 0.2 m/s: it must come back at 0.2 m/s (within 0.5 %),
  // and the 50-sub-step integration agrees with a 2000-sub-step one to 1 µm.
  auto run = [](int substeps) {
    LoopbackPlantConfig config = WallSlave(5000.0, 0.0);
    config.damping_Ns_per_m = 0.0;
    config.contact_substeps = substeps;
    config.initial_position_m = One(0.0);
    config.initial_velocity_m_per_s = One(0.2);
    LoopbackPlant plant(config);
    double deepest = 0.0;
    for (int k = 0; k < 150; ++k) {
      plant.Update(0.001);
      deepest = std::max(deepest, plant.true_position_m()[0]);
    }
    return std::array<double, 3>{plant.true_position_m()[0], plant.true_velocity_m_per_s()[0], deepest};
  };
  const auto fine = run(2000);
  const auto coarse = run(50);
  const double fine_deepest = fine[2];
  EXPECT_NEAR(fine[1], -0.2, 0.001);
  EXPECT_NEAR(coarse[1], -0.2, 0.001);
  EXPECT_NEAR(coarse[0], fine[0], 1e-6);
  // Maximum depth of an elastic impact: v·sqrt(m/k) = 0.2·sqrt(0.036/5000) = 0.537 mm (sampled, so ≤).
  EXPECT_NEAR(fine_deepest - 0.01, 0.2 * std::sqrt(0.036 / 5000.0), 2e-5);
}

TEST(LoopbackPlant, BadCommandsAndPeriodsAreRejectedAndReported) {
  LoopbackPlant plant(LoopbackPlantConfig::PaperSlave());
  plant.Write(Command::Force(One(1.0)));
  plant.Write(Command::Force(One(std::numeric_limits<double>::quiet_NaN())));
  EXPECT_EQ(plant.held_command_N()[0], 0.0);  // never integrate NaN: zero force instead
  plant.Update(0.001);
  Reading reading;
  plant.Read(reading);
  EXPECT_NE(reading.faults & kFaultDriver, 0u);
  EXPECT_TRUE(reading.position_m.allFinite());
  EXPECT_EQ(plant.true_position_m()[0], 0.0);
  plant.Read(reading);
  EXPECT_EQ(reading.faults, kFaultNone);            // reported once
  plant.Write(Command::Force(DofVector::Zero(3)));  // wrong size
  plant.Update(-1.0);
  plant.Update(std::numeric_limits<double>::infinity());
  EXPECT_EQ(plant.time_s(), 0.001);
  EXPECT_EQ(plant.rejected_commands(), 2u);
  EXPECT_EQ(plant.rejected_updates(), 2u);
  plant.SetDisturbance(One(std::numeric_limits<double>::quiet_NaN()));
  plant.Update(0.001);
  EXPECT_TRUE(plant.true_position_m().allFinite());
}

TEST(LoopbackPlant, SetSafeZeroesTheCommand) {
  LoopbackPlant plant(LoopbackPlantConfig::PaperSlave());
  plant.Write(Command::Force(One(3.0)));
  plant.SetSafe();
  plant.Update(0.01);
  EXPECT_EQ(plant.true_position_m()[0], 0.0);
}

TEST(LoopbackPlant, RejectsBadConfigNamingTheField) {
  auto expect_error = [](const LoopbackPlantConfig& config, const std::string& word) {
    try {
      LoopbackPlant plant(config);
      ADD_FAILURE() << "accepted a config that should fail on " << word;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
  };
  LoopbackPlantConfig c;
  c.mass_kg = 0.0;
  expect_error(c, "mass_kg");
  c = {};
  c.damping_Ns_per_m = -0.1;
  expect_error(c, "damping_Ns_per_m");
  c = {};
  c.dof = 0;
  expect_error(c, "dof");
  c = {};
  c.initial_position_m = DofVector::Zero(2);
  expect_error(c, "initial_position_m");
  c = {};
  c.force_sensor_noise_N = 0.1;
  expect_error(c, "force_sensor_noise_N");
  c = {};
  c.human.enabled = true;
  c.human.segment_count = 1;
  c.human.segments[0] = {Kind::kRamp, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0};
  expect_error(c, "segments[0].duration_s");
  c.human.segments[0] = {Kind::kStep, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 3};
  expect_error(c, "axis");
  c = {};
  c.environment.kind = SimulatedEnvironmentConfig::Kind::kWall;
  c.environment.stiffness_N_per_m = -5.0;
  expect_error(c, "environment.stiffness_N_per_m");
}

}  // namespace
}  // namespace teleop::device
