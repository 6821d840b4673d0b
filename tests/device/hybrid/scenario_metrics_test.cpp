// The paper's experiments on the simulated rig (docs/hybrid.md): checked against what Kwon & Song state (bounce
// counts, orders of magnitude), not against our model's own numbers. Models: motor torque lag 0.5 ms (current loop),
// brake lag 50 ms (§2.2), encoders, force sensor noise, brake remanence and joint friction on (defaults).
#include <gtest/gtest.h>

#include <cmath>

#include "hybrid/contact_scenarios.hpp"

namespace teleop::device::hybrid {
namespace {

ContactMetrics Wall(WallKind kind, double speed_m_per_s) {
  return RunWallScenario(PaperWallScenario(kind, speed_m_per_s)).metrics;
}

// Fig. 8(c)/9(c): "For the hybrid system, the transient period was about 0.11 s, but no bounce was observed. A large
// steady-state error of 1.2 mm occurred"; at 1500 mm/s "the hybrid system did not exhibit any bounce ... the
// steady-state error was very large up to about 20 mm". Tolerances: no bounce exactly; the errors to their order of
// magnitude (1.2 mm within a factor 3, 20 mm within a factor 2: the paper gives no inertias, and docs/hybrid.md's
// sensitivity table moves them by that much). Brakes dissipate.
TEST(HybridScenarios, HybridWallNeverBouncesAndStopsWithPaperLikePenetration) {
  const ContactMetrics weak = Wall(WallKind::kHybrid, 0.25);
  EXPECT_EQ(weak.bounces, 0);
  EXPECT_GT(weak.steady_state_error_mm, 1.2 / 3.0);
  EXPECT_LT(weak.steady_state_error_mm, 1.2 * 3.0);
  EXPECT_LT(weak.brake_energy_J, 0.0);
  const ContactMetrics strong = Wall(WallKind::kHybrid, 1.5);
  EXPECT_EQ(strong.bounces, 0);
  EXPECT_GT(strong.steady_state_error_mm, 20.0 / 2.0);
  EXPECT_LT(strong.steady_state_error_mm, 20.0 * 2.0);
  // The deep error is the penetration before the brake holds: the steady state is the maximum depth (no rebound).
  EXPECT_NEAR(strong.steady_state_error_mm, strong.max_depth_mm, 0.5);
}

// The realism a controller meets (docs/hybrid.md, Realism) does not make the hybrid wall's "no bounce" (Fig. 8(c)/9(c):
// "no bounce was observed", "did not exhibit any bounce") a coincidence of one setting: with ideal sensors (exact
// encoders and velocity, no force noise), a coarse encoder (4000 counts per joint revolution) or a brake without
// remanence and static torque, it still never bounces at either speed. (The allocation's brake model does not enter
// here: the wall asks the brakes alone for the hold, at full command, and the motors alone for the damper; the model
// only sets the motor's share of a shared request, MotorBrakeAllocation.AMismatchedBrakeModelRendersLessNeverMore.)
TEST(HybridScenarios, HybridWallNoBounceDoesNotHangOnTheRealismSettings) {
  enum Variant { kIdealSensors, kCoarseEncoder, kPlainBrake };
  for (Variant variant : {kIdealSensors, kCoarseEncoder, kPlainBrake}) {
    for (double speed : {0.25, 1.5}) {
      WallScenarioConfig c = PaperWallScenario(WallKind::kHybrid, speed);
      if (variant == kIdealSensors) {
        c.rig.encoders.counts_per_joint_rev = 0.0;
        c.rig.encoders.exact_velocity = true;
        c.rig.force_sensor_dynamics.noise_std_N = 0.0;
      } else if (variant == kCoarseEncoder) {
        c.rig.encoders.counts_per_joint_rev = 4000.0;
      } else {
        c.rig.brake.residual_fraction = 0.0;
        c.rig.brake.static_ratio = 1.0;
      }
      EXPECT_EQ(RunWallScenario(c).metrics.bounces, 0) << "variant " << variant << " speed " << speed;
    }
  }
}

// §4: "The instant the contact with the virtual wall occurs, the brakes are activated and the motors generate the
// damping force" — motors and brakes act in parallel and their forces add (Fig. 6(a)): during the strong contact there
// are cycles where the motors give the saturated damper force (> 90 N of their 100 N) while the brakes add more than
// 30 N, and the push-back exceeds what the motors alone can give ("a contact force over 100 N"). Before, the motor
// gave the damper force minus the brake's estimate and the total was max(damper, brake): about 112 N at most.
TEST(HybridScenarios, HybridWallMotorsAndBrakesAdd) {
  const ScenarioResult r = RunWallScenario(PaperWallScenario(WallKind::kHybrid, 1.5));
  int both = 0;
  for (const ScenarioSample& s : r.samples) {
    if (s.motor_normal_N > 90.0 && s.brake_normal_N > 30.0) {
      ++both;
      EXPECT_NEAR(s.rendered_normal_N, s.motor_normal_N + s.brake_normal_N, 3.0);  // + joint friction (≤ 1 N)
    }
  }
  EXPECT_GT(both, 3);
  EXPECT_GT(r.metrics.peak_force_N, 130.0);
}

// The paper gives neither the operator's hand mass nor the motors' torque lag; the statements below are checked over a
// small grid of both (docs/hybrid.md, sensitivity): hand 0.2, 0.5, 1.0 kg × lag 0.5, 2 ms, at 1500 mm/s.
WallScenarioConfig Varied(WallKind kind, double hand_mass_kg, double motor_lag_s) {
  WallScenarioConfig c = PaperWallScenario(kind, 1.5);
  c.hand_mass_kg = hand_mass_kg;
  c.rig.motor.time_constant_s = motor_lag_s;
  c.allocation.motor = c.rig.motor;
  c.wall.popc.actuator_time_constant_s = motor_lag_s;
  return c;
}

constexpr double kHandMasses_kg[] = {0.2, 0.5, 1.0};
constexpr double kMotorLags_s[] = {0.5e-3, 2e-3};

// Fig. 9(a): "The pure active system suffered unstable oscillation and big bounces" (150 N/mm, 1500 mm/s): over the
// grid it bounces more than once by over 1 mm. (Whether the motors' net work over the run is positive depends on the
// hand mass, lag and contact speed, so it is not a statement to check.)
TEST(HybridScenarios, ActiveSpringWallBouncesAtHighSpeed) {
  for (double hand : kHandMasses_kg) {
    for (double lag : kMotorLags_s) {
      const ContactMetrics m = RunWallScenario(Varied(WallKind::kSpring, hand, lag)).metrics;
      EXPECT_GE(m.big_bounces, 2) << hand << " kg, " << lag << " s";
    }
  }
}

// Fig. 8(b)/9(b): "For the PO/PC based system, only one bounce occurred at the initial contact and a small steady-state
// error existed"; at 1500 mm/s "the PO/PC based system showed one big bounce and then stable response. A small
// steady-state error was observed". Tolerances: at most one separation over 1 mm ("big", docs/hybrid.md) at either
// speed, one at 1500 mm/s; "small" against the hybrid's 20 mm: under 2 mm (the 150 N/mm spring against the 80 N push is
// 0.53 mm). And it is passive: the motors do no net work on the hand (before the fix: +1.98 J at 1500 mm/s), within
// 0.05 J (the energy of one step at 100 N and 0.5 m/s).
TEST(HybridScenarios, PoPcOneBounceAndSmallErrorAtBothSpeeds) {
  for (double speed : {0.25, 1.5}) {
    const ContactMetrics m = Wall(WallKind::kSpringPoPc, speed);
    EXPECT_LE(m.big_bounces, 1) << speed;
    EXPECT_GE(m.bounces, 1) << speed;
    EXPECT_LT(std::abs(m.steady_state_error_mm), 2.0) << speed;
    EXPECT_LT(m.motor_energy_J, 0.05) << speed;
  }
}

// "One big bounce, then stable; small steady-state error" at 1500 mm/s, over the hand-mass × lag grid: the count of
// big bounces moves with the hand and the lag (0 to 3: exactly one holds at the defaults only), what holds is that it
// settles (no separation in the last 0.1 s of the 0.8 s run; with a 1 kg hand the last is at 0.65 s) with a small
// error (under 2 mm, under a quarter of the hybrid's). Passivity (no net motor work) is checked at the defaults above;
// over the grid it is not a paper statement and does not hold everywhere (+0.066 J with a 0.2 kg hand and 2 ms lag,
// docs/hybrid.md).
TEST(HybridScenarios, PoPcSettlesPassivelyWithASmallErrorOverTheGrid) {
  for (double hand : kHandMasses_kg) {
    for (double lag : kMotorLags_s) {
      const ScenarioResult r = RunWallScenario(Varied(WallKind::kSpringPoPc, hand, lag));
      const ContactMetrics& m = r.metrics;
      const ContactMetrics hybrid = RunWallScenario(Varied(WallKind::kHybrid, hand, lag)).metrics;
      double last_out_s = 0.0;
      for (const ScenarioSample& s : r.samples) {
        if (s.depth_m < -0.1e-3 && m.contact_time_s >= 0.0 && s.time_s > m.contact_time_s) last_out_s = s.time_s;
      }
      EXPECT_LT(last_out_s, 0.7) << hand << " kg, " << lag << " s";
      EXPECT_LE(m.big_bounces, 3) << hand << " kg, " << lag << " s";
      EXPECT_LT(std::abs(m.steady_state_error_mm), 2.0) << hand << " kg, " << lag << " s";
      EXPECT_LT(std::abs(m.steady_state_error_mm), 0.25 * hybrid.steady_state_error_mm) << hand << " kg, " << lag;
    }
  }
}

// Fig. 7(a), §4: "the unstable condition was observed in the velocity range of 20–40 mm/s when the damper model with
// large coefficients was employed". The linear damper of 2500 N·s/m (100 N at 40 mm/s) on the motors, met at 20, 30 and
// 40 mm/s with a 25 N push, bounces repeatedly (≥ 3 separations); the cubic damper (F = 1.6·10⁶ v³) at most once.
TEST(HybridScenarios, Fig7aLinearDamperIsUnstableAtTwentyToFortyMillimetresPerSecond) {
  for (double speed : {0.020, 0.030, 0.040}) {
    const ContactMetrics linear = RunWallScenario(PaperDamperScenario(WallKind::kLinearDamper, speed, false)).metrics;
    const ContactMetrics cubic = RunWallScenario(PaperDamperScenario(WallKind::kHybrid, speed, false)).metrics;
    EXPECT_GE(linear.bounces, 3) << speed;
    EXPECT_LE(cubic.bounces, 1) << speed;
  }
}

// The documented Fig. 7(a) command, `hybrid-wall --model linear-damper --speed-mm-s 30 --no-brakes`, meets the
// damper wall (it used to run the §4 contact, 50 mm away for 0.8 s at 30 mm/s: contact_time_s −1) and chatters on it.
TEST(HybridScenarios, LinearDamperModelRunsTheFig7aContact) {
  WallScenarioConfig c = ScenarioForModel(WallKind::kLinearDamper, 0.030);
  c.allocation.use_brakes = false;
  const ContactMetrics m = RunWallScenario(c).metrics;
  EXPECT_GE(m.contact_time_s, 0.0);
  EXPECT_GT(m.velocity_reversals, 0);
  EXPECT_GE(m.bounces, 3);
}

// Fig. 5(b) on the wall (§3: "when the reaction force of the virtual wall is larger than the force exerted by the human
// operator and the end-effector is released ... the brake can exert only a reaction force against its outward
// motion"). The hybrid wall with Fig. 6(a)'s spring (20 N/mm, below the 25 N push at the hybrid's 0.5 mm stop): held,
// the brakes resist the push and the handle stays; when the hand lets go (0.4 s) the spring's reaction is the larger,
// the allocation releases the brakes and the motors push the handle back towards the surface. Without the spring (Table
// 1's damper + brake) nothing pushes it out: it stays where the brakes stopped it.
TEST(HybridScenarios, Fig5bTheSpringPushesTheHandleOutWhenTheHandLetsGo) {
  const auto at = [](const ScenarioResult& r, double t_s) {
    return r.samples[static_cast<std::size_t>(std::lround(t_s / 0.001)) - 1];
  };
  const ScenarioResult spring = RunWallScenario(PaperReleaseScenario(20e3));
  const ScenarioResult plain = RunWallScenario(PaperReleaseScenario(0.0));
  const ScenarioSample held = at(spring, 0.39);
  ASSERT_GT(held.depth_m, 0.2e-3);                                      // stopped inside the wall
  EXPECT_GT(held.brake_capacity_1_Nm + held.brake_capacity_2_Nm, 5.0);  // the brakes hold against the hand
  double spring_end_min = held.depth_m;
  double plain_end_min = at(plain, 0.39).depth_m;
  for (double t = 0.45; t <= 0.8; t += 0.001) {
    spring_end_min = std::min(spring_end_min, at(spring, t).depth_m);
    plain_end_min = std::min(plain_end_min, at(plain, t).depth_m);
  }
  EXPECT_LT(spring_end_min, 0.6 * held.depth_m);  // pushed back: 0.49 → 0.24 mm (friction and remanence stop it)
  const ScenarioSample late = at(spring, 0.6);
  EXPECT_LT(late.brake_capacity_1_Nm + late.brake_capacity_2_Nm,
            0.2 * (held.brake_capacity_1_Nm + held.brake_capacity_2_Nm));  // released: remanence and drag only
  EXPECT_GT(plain_end_min, 0.8 * at(plain, 0.39).depth_m);                 // no spring: it stays
}

// The nominal contact speed: the hand's arm overshoots (1500 mm/s intended reaches the wall faster); calibrated, the
// measured contact speed is the nominal one within 0.1 %.
TEST(HybridScenarios, ContactSpeedCalibration) {
  const ContactMetrics nominal = Wall(WallKind::kHybrid, 1.5);
  EXPECT_GT(nominal.contact_speed_mm_s, 1550.0);
  const ContactMetrics at = RunWallScenario(PaperWallScenarioAtContactSpeed(WallKind::kHybrid, 1.5)).metrics;
  EXPECT_NEAR(at.contact_speed_mm_s, 1500.0, 1.5);
  EXPECT_LT(at.commanded_speed_mm_s, 1500.0);
  EXPECT_EQ(at.bounces, 0);
}

// §5: the brakes show the friction without doing positive work on the handle; the motors' friction is clipped to
// the hand's tangential force. Both slide the full 120 mm at the hand's 100 mm/s with a stable normal contact.
TEST(HybridScenarios, FrictionDisplayByBrakesAndByMotors) {
  for (FrictionDisplay d : {FrictionDisplay::kBrake, FrictionDisplay::kMotor}) {
    for (double normal : {25.0, 40.0}) {
      const ContactMetrics m = RunFrictionScenario(PaperFrictionScenario(d, normal)).metrics;
      EXPECT_EQ(m.bounces, 0) << ToString(d) << " " << normal;
      EXPECT_NEAR(m.slide_mm, 116.0, 8.0) << ToString(d) << " " << normal;
      EXPECT_LT(m.friction_rms_error_N, 0.2 * normal) << ToString(d) << " " << normal;
      EXPECT_LT(m.friction_positive_work_J, 0.005) << ToString(d) << " " << normal;
      EXPECT_LE(m.brake_energy_J, 0.0);
    }
  }
}

}  // namespace
}  // namespace teleop::device::hybrid
