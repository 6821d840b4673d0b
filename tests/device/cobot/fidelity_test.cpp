// Issue 19: the cobot against Colgate, Wannasuphoprasit & Peshkin (docs/cobot.md). Each check compares with a
// statement of the paper or a closed form derived by hand, not with the model's own output:
//  - the bicycle's virtual caster is a point mass (§3.1) in every direction, with one mass;
//  - a cobot is refused as the slave (passive: it cannot follow a master);
//  - the eq 10 guard's warning reaches Reading::warnings;
//  - the bicycle measures the handle force it claims to measure, and its controllers see the plate through encoders
//    (the twist from the two wheels' rolling, the rates by differentiation and filtering, §3.2);
//  - a fault near a fixture cannot push the cart through it;
//  - the overlay arc (§5, Fig. 8) against hand-computed geometry;
//  - the friction limit (μ·N): "impossible to push the unicycle past a virtual constraint (unless the wheel slips)".
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

#include "device/cobot/bicycle_caster.hpp"
#include "device/cobot/bicycle_plant.hpp"
#include "device/cobot/bicycle_sensing.hpp"
#include "device/cobot/cobot_backend.hpp"
#include "device/cobot/constraint_overlay.hpp"
#include "device/cobot/unicycle_plant.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"

namespace teleop::device::cobot {
namespace {

constexpr double kPeriod_s = 0.001;
constexpr double kDeg = std::numbers::pi / 180.0;

std::any ReadSection(const std::string& yaml, int dof, Role role = Role::kMaster) {
  static const std::string file = "test.yaml";
  const YAML::Node node = YAML::Load(yaml);
  const config::Field field(node, "device.cobot", &file);
  return FindDevice("cobot")->read(&field, SectionContext{role, dof});
}

// ---------------------------------------------------------------- defect 1: one isotropic virtual mass

TEST(CobotFidelity, BicycleCasterIsOnePointMassInEveryDirection) {
  // §3.1: "for a point mass, the acceleration and force vectors are collinear and in fixed proportion". A constant
  // force F on a point mass M moving at v0 gives v(T) = v0 + F·T/M exactly, whatever the angle between F and v0.
  // The plate is pushed at its origin (no moment), at several plate angles and wheel headings, across the wheels
  // (±90°), and obliquely (45°, 135°). Rolling resistance is off so the plate's own mass is all there is along the
  // wheels. Tolerance 4 %: the steering loop lags the lateral acceleration by τ = 20 ms, τ/T = 2 % of T = 1 s.
  const auto c = std::any_cast<CobotBackendConfig>(ReadSection("{kind: bicycle}", 3));
  BicyclePlantConfig plant = c.bicycle;
  plant.rolling_damping_Ns_per_m = 0.0;
  const double mass = plant.plate_mass_kg;
  constexpr double kSpeed = 0.3;
  constexpr double kForce_N = 3.0;
  constexpr double kDuration_s = 1.0;
  for (const double plate_deg : {0.0, 40.0, -70.0}) {
    for (const double steer_deg : {0.0, 30.0, -45.0}) {
      for (const double force_deg : {90.0, -90.0, 45.0, 135.0}) {
        BicyclePlantState s;
        s.pose.angle_rad = plate_deg * kDeg;
        s.steer_rad = {steer_deg * kDeg, steer_deg * kDeg};
        const double heading = (plate_deg + steer_deg) * kDeg;
        s.twist << kSpeed * std::cos(heading), kSpeed * std::sin(heading), 0.0;
        const Vec2 v0(s.twist(0), s.twist(1));
        const Vec2 force = kForce_N * UnitAt(heading + force_deg * kDeg);
        for (int k = 0; k < static_cast<int>(kDuration_s / kPeriod_s); ++k) {
          const BicycleCasterOutput out = BicycleCasterStep(c.bicycle_caster, plant.geometry, s, force, 0.0);
          BicyclePlantInput in;
          in.handle_force_N = force;
          in.steering_torque_Nm = out.steering_torque_Nm;
          Step(plant, in, kPeriod_s, s);
        }
        const Vec2 dv = Vec2(s.twist(0), s.twist(1)) - v0;
        const Vec2 expected = force * kDuration_s / mass;
        const double apparent_along_force_kg = kForce_N * kForce_N * kDuration_s / force.dot(dv);
        EXPECT_LT((dv - expected).norm(), 0.04 * expected.norm())
            << "plate " << plate_deg << "°, wheels " << steer_deg << "°, force at " << force_deg
            << "° to the motion: Δv (" << dv.x() << ", " << dv.y() << "), a point mass of " << mass << " kg gives ("
            << expected.x() << ", " << expected.y() << "); apparent mass " << apparent_along_force_kg << " kg";
        EXPECT_NEAR(s.twist(2), 0.0, 1e-6);  // no moment, no rotation
      }
    }
  }
}

TEST(CobotFidelity, BicycleHasNoSeparateVirtualMassKey) {
  // One mass, one key: the plate's. `virtual_mass_kg` (the unicycle's 1/K1) is refused for a bicycle.
  const auto c = std::any_cast<CobotBackendConfig>(ReadSection("{kind: bicycle, bicycle: {plate_mass_kg: 20}}", 3));
  EXPECT_DOUBLE_EQ(c.bicycle_caster.virtual_mass_kg, 20.0);
  EXPECT_DOUBLE_EQ(c.bicycle_caster.virtual_inertia_kgm2, c.bicycle.plate_inertia_kgm2);
  try {
    ReadSection("{kind: bicycle, virtual_mass_kg: 10}", 3);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("plate_mass_kg"), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------- defect 2: not a slave

TEST(CobotFidelity, RefusedAsTheSlaveWithTheReason) {
  for (const std::string& yaml : {std::string("{}"), std::string("{kind: bicycle}")}) {
    try {
      ReadSection(yaml, yaml == "{}" ? 2 : 3, Role::kSlave);
      FAIL() << "a cobot slave was accepted: " << yaml;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("slave"), std::string::npos) << what;
      EXPECT_NE(what.find("passive"), std::string::npos) << what;
      EXPECT_NE(what.find("test.yaml"), std::string::npos) << what;  // where
    }
  }
  // Without a section (device.cobot is optional) the reader refuses it too.
  EXPECT_THROW(FindDevice("cobot")->read(nullptr, SectionContext{Role::kSlave, 2}), Error);
  EXPECT_NO_THROW(FindDevice("cobot")->read(nullptr, SectionContext{Role::kMaster, 2}));
}

// ---------------------------------------------------------------- defect 3: the guard's warning

Command WithPlane(int dof, double nx, double ny, double offset_m) {
  Command c = Command::Force(DofVector::Zero(dof));
  c.constraint_count = 1;
  c.constraints[0].normal = DofVector::Zero(dof);
  c.constraints[0].normal[0] = nx;
  c.constraints[0].normal[1] = ny;
  c.constraints[0].offset_m = offset_m;
  return c;
}

CobotBackendConfig Pushing(double direction_deg, double lookahead_m) {
  CobotBackendConfig c;
  c.op.enabled = true;
  c.op.speed_m_per_s = 0.2;
  c.op.direction_deg = direction_deg;
  c.initial.heading_rad = direction_deg * kDeg;
  c.unicycle.controller.tracker.lookahead_m = lookahead_m;
  return c;
}

struct WarningCount {
  int set = 0;
  int set_while_caster = 0;
  bool last = false;
};

template <typename DeviceT>
WarningCount CountWarnings(DeviceT& device, const Command& command, int steps) {
  WarningCount w;
  Reading r;
  for (int k = 0; k < steps; ++k) {
    device.Read(r);
    const bool warn = (r.warnings & kWarningStabilityGuard) != 0;
    w.set += warn ? 1 : 0;
    w.set_while_caster += warn && device.controller_mode() == WallMode::kCaster ? 1 : 0;
    w.last = warn;
    device.Write(command);
    device.Update(kPeriod_s);
  }
  return w;
}

TEST(CobotFidelity, StabilityGuardWarningReachesTheReading) {
  // Eq 11: tracking is stable for uτ < L. At u = 0.2 m/s and τ = 20 ms, uτ = 4 mm: L = 2 mm is above the guard's
  // 0.8 margin (u > 0.8·L/τ = 0.08 m/s), L = 50 mm far below it (2 m/s).
  for (const double lookahead : {0.002, 0.05}) {
    CobotBackendConfig c = Pushing(45.0, lookahead);
    c.op.then_at_s = 1.5;
    c.op.then_direction_deg = -90.0;  // pulls off the wall: back to caster, the warning clears
    UnicycleCobotDevice device(c);
    const WarningCount w = CountWarnings(device, WithPlane(2, 0.0, 1.0, 0.1), 2500);
    if (lookahead < 0.01) {
      EXPECT_GT(w.set, 100) << "unstable lookahead: no warning";
    } else {
      EXPECT_EQ(w.set, 0) << "stable lookahead warned";
    }
    EXPECT_EQ(w.set_while_caster, 0);
    EXPECT_FALSE(w.last);  // released: caster, no warning
  }
  // The bicycle's wall controller (its reference point as a unicycle) reports the same way.
  for (const double lookahead : {0.002, 0.05}) {
    CobotBackendConfig c = Pushing(45.0, lookahead);
    c.kind = CobotBackendConfig::Kind::kBicycle;
    BicycleCobotDevice device(c);
    const WarningCount w = CountWarnings(device, WithPlane(3, 0.0, 1.0, 0.1), 2000);
    if (lookahead < 0.01) {
      EXPECT_GT(w.set, 100) << "bicycle, unstable lookahead: no warning";
    } else {
      EXPECT_EQ(w.set, 0) << "bicycle, stable lookahead warned";
    }
  }
}

// ---------------------------------------------------------------- defect 4: the bicycle's force sensor

TEST(CobotFidelity, BicycleMeasuresTheHandleForceItClaims) {
  CobotBackendConfig c = Pushing(30.0, 0.05);
  c.kind = CobotBackendConfig::Kind::kBicycle;
  BicycleCobotDevice device(c);
  ASSERT_TRUE(device.capabilities().measures_force);
  Reading r;
  double largest_N = 0.0;
  for (int k = 0; k < 500; ++k) {
    device.Write(Command::Force(DofVector::Zero(3)));
    device.Update(kPeriod_s);
    device.Read(r);
    ASSERT_EQ(r.force_N.size(), 3);
    const Vec2 truth = device.operator_force_N();
    // The sensor's quantization step (force_resolution_N) bounds the error: half a step.
    EXPECT_NEAR(r.force_N[0], truth.x(), 0.5 * c.unicycle.sensors.force_resolution_N + 1e-12);
    EXPECT_NEAR(r.force_N[1], truth.y(), 0.5 * c.unicycle.sensors.force_resolution_N + 1e-12);
    largest_N = std::max(largest_N, std::hypot(r.force_N[0], r.force_N[1]));
  }
  EXPECT_GT(largest_N, 1.0);  // the operator pushes: the reading is not the old constant 0
}

// ---------------------------------------------------------------- defect 6: the bicycle's sensor model

/// A plate state moving with the twist (v, Ω), each wheel steered along its contact point's velocity (rolling
/// without slip): the rigid-body kinematics by hand, v_i = v + Ω·(−r_i.y, r_i.x), β_i = atan2(v_i) − θ.
BicyclePlantState Rolling(const BicycleGeometry& g, double plate_rad, const Vec2& v, double omega,
                          double wheel_fallback_rad = 0.0) {
  BicyclePlantState s;
  s.pose.angle_rad = plate_rad;
  s.twist << v.x(), v.y(), omega;
  for (int i = 0; i < 2; ++i) {
    const double side = i == 0 ? -1.0 : 1.0;
    const Vec2 r = side * g.half_wheelbase_m * UnitAt(plate_rad);
    const Vec2 vi = v + omega * Vec2(-r.y(), r.x());
    s.steer_rad[static_cast<std::size_t>(i)] =
        vi.norm() > 1e-12 ? std::atan2(vi.y(), vi.x()) - plate_rad : wheel_fallback_rad;
  }
  return s;
}

TEST(CobotFidelity, BicycleSeesItsTwistThroughTheWheelAndSteeringEncoders) {
  // §3.2: "u and ω are estimated by digital differentiation and digital filtering of the associated angular
  // measures". The bicycle's controllers see each wheel's rolling speed and steering rate that way, and the plate's
  // twist from the two wheels (two points fix a planar rigid motion). Checked against the rigid motion, including
  // the singular configuration (both wheels across their line, the plate turning about wheel 0).
  const BicycleGeometry g;
  const UnicycleCobotConfig rig = UnicycleCobotConfig::Prototype();
  struct Case {
    const char* what;
    BicyclePlantState state;
  };
  const Case cases[] = {
      {"translation at 30° (plate at 10°)", Rolling(g, 10.0 * kDeg, 0.3 * UnitAt(30.0 * kDeg), 0.0)},
      {"turning about (0, 0.5 m) at 0.4 rad/s", Rolling(g, 0.0, {0.2, 0.0}, 0.4)},
      {"singular: wheels across their line, turning about wheel 0",
       Rolling(g, 0.0, {0.0, 0.1}, 0.5, 0.5 * std::numbers::pi)},
      {"turning in place at 1 rad/s (plate at -40°)", Rolling(g, -40.0 * kDeg, {0.0, 0.0}, 1.0)},
  };
  for (const Case& c : cases) {
    for (const bool ideal : {true, false}) {
      CobotSensorConfig sensors = rig.sensors;
      if (ideal) {
        sensors.wheel_encoder_counts_per_rev = 0;
        sensors.steering_encoder_counts_per_rev = 0;
      }
      BicycleSensing sensing(sensors, rig.speed_filter, rig.steering_rate_filter, g);
      sensing.Reset(c.state);
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      constexpr int kSteps = 400;
      for (int k = 0; k < kSteps; ++k) {
        const BicyclePlantState seen = sensing.Measure(c.state, kPeriod_s);
        if (k >= kSteps / 2) mean += seen.twist / (kSteps / 2);
        if (ideal) {
          EXPECT_NEAR(seen.twist(0), c.state.twist(0), 1e-9) << c.what;
          EXPECT_NEAR(seen.twist(1), c.state.twist(1), 1e-9) << c.what;
          EXPECT_NEAR(seen.twist(2), c.state.twist(2), 1e-9) << c.what;
        }
        sensing.Roll(c.state, kPeriod_s);
      }
      // Quantized (16384 counts: 19 µm of rolling, 0.38 mrad of steering): the mean over 0.2 s within 1 mm/s and
      // 1 mm/s over the half wheelbase.
      EXPECT_NEAR(mean(0), c.state.twist(0), 1e-3) << c.what;
      EXPECT_NEAR(mean(1), c.state.twist(1), 1e-3) << c.what;
      EXPECT_NEAR(mean(2), c.state.twist(2), 1e-3 / g.half_wheelbase_m) << c.what;
    }
  }
  // A speed step seen through the backward difference and the 50 Hz low-pass: after the first difference,
  // û(n) = u·(1 − e^(−2π·50 Hz·n·h)); the steering rate through its 100 Hz filter likewise.
  CobotSensorConfig ideal = rig.sensors;
  ideal.wheel_encoder_counts_per_rev = 0;
  ideal.steering_encoder_counts_per_rev = 0;
  BicycleSensing sensing(ideal, rig.speed_filter, rig.steering_rate_filter, g);
  BicyclePlantState s = Rolling(g, 0.0, {0.0, 0.0}, 0.0);
  sensing.Reset(s);
  (void)sensing.Measure(s, kPeriod_s);
  s = Rolling(g, 0.0, {0.2, 0.0}, 0.0);
  sensing.Roll(s, kPeriod_s);
  const double steer_rate = 0.5;
  for (int n = 1; n <= 20; ++n) {
    s.steer_rad = {steer_rate * (n - 1) * kPeriod_s, steer_rate * (n - 1) * kPeriod_s};
    s.steer_rate_rad_per_s = {steer_rate, steer_rate};
    const BicyclePlantState seen = sensing.Measure(s, kPeriod_s);
    const double wheel = 0.2 * (1.0 - std::exp(-2.0 * std::numbers::pi * 50.0 * n * kPeriod_s));
    EXPECT_NEAR(std::hypot(seen.twist(0), seen.twist(1)), wheel, 1e-9) << "step " << n;
    if (n >= 2) {
      const double rate = steer_rate * (1.0 - std::exp(-2.0 * std::numbers::pi * 100.0 * (n - 1) * kPeriod_s));
      EXPECT_NEAR(seen.steer_rate_rad_per_s[0], rate, 1e-9) << "step " << n;
    }
    sensing.Roll(Rolling(g, 0.0, {0.2, 0.0}, 0.0), kPeriod_s);
  }
}

// ---------------------------------------------------------------- isotropy with the plate turning, through the sensors

TEST(CobotFidelity, BicycleCasterIsOnePointMassWhileTurningSeenThroughTheEncoders) {
  // The point-mass property of BicycleCasterIsOnePointMassInEveryDirection with the plate rotating: it starts with a
  // twist (v0, Ω0), each wheel rolling along its contact point's velocity (so the wheels are not parallel), and a
  // constant force F at the plate origin (no moment). A free rigid plate (§3.1) then has v(T) = v0 + F·T/M and keeps
  // Ω(T) = Ω0: the caster must steer each wheel for a_i = a + α×r_i − Ω²r_i, centripetal term included. Run twice:
  // on the true state, and on what BicycleSensing makes of the 16384-count wheel and steering encoders (the rates by
  // backward difference and the 50/100 Hz low-pass), as the device does.
  // Tolerances: 4 % on the true state (the steering loop's τ = 20 ms over T = 1 s, as the parallel-wheel test). The
  // encoders add (i) the speed filter's lag, 1/(2π·50 Hz) + h/2 = 3.7 ms, i.e. 0.4 % of the Δv reached in T, and
  // (ii) the quantization: a wheel count is 2π·R/16384 = 19 µm, up to 19 mm/s in one 1 ms difference, filtered to a
  // few mm/s of zero-mean noise; a steering count is 0.38 mrad. We allow 1 % of F·T/M for both (the encoder run
  // against the true-state run), 5 % against the point mass.
  // The starts keep the instantaneous centre off the wheels' line (checked: the singularity guard never acts). A
  // start driven onto that line (plate 30°, travel 60°, Ω0 −0.8 rad/s) misses the point mass by 26-94 % with the
  // guard, 12-77 % without: near the singularity (§2) the plate's twist is set by the small difference of the two
  // wheel angles, so the steering lag is amplified. That is the configuration, not the caster.
  const auto c = std::any_cast<CobotBackendConfig>(ReadSection("{kind: bicycle}", 3));
  BicyclePlantConfig plant = c.bicycle;
  plant.rolling_damping_Ns_per_m = 0.0;
  BicycleCasterConfig caster = c.bicycle_caster;
  caster.rolling_damping_Ns_per_m = 0.0;
  const double mass = plant.plate_mass_kg;
  constexpr double kSpeed = 0.3;
  constexpr double kForce_N = 3.0;
  constexpr double kDuration_s = 1.0;
  struct Start {
    double plate_deg, travel_deg, omega_rad_per_s;
  };
  const Start starts[] = {{0.0, 0.0, 0.5}, {30.0, 60.0, 0.8}, {-50.0, -20.0, 0.8}, {90.0, 30.0, -0.5}};
  struct Outcome {
    Vec2 dv;
    double omega_rad_per_s;
  };
  double least_measure = 1.0;
  auto run = [&](BicyclePlantState s, const Vec2& force, bool through_sensors) {
    BicycleSensing sensing(c.unicycle.sensors, c.unicycle.speed_filter, c.unicycle.steering_rate_filter,
                           plant.geometry);
    sensing.Reset(s);
    const Vec2 v0(s.twist(0), s.twist(1));
    for (int k = 0; k < static_cast<int>(kDuration_s / kPeriod_s); ++k) {
      const BicyclePlantState seen = through_sensors ? sensing.Measure(s, kPeriod_s) : s;
      const BicycleCasterOutput out = BicycleCasterStep(caster, plant.geometry, seen, force, 0.0);
      least_measure = std::min(least_measure, out.singularity_measure);
      BicyclePlantInput in;
      in.handle_force_N = force;
      in.steering_torque_Nm = out.steering_torque_Nm;
      Step(plant, in, kPeriod_s, s);
      sensing.Roll(s, kPeriod_s);
    }
    return Outcome{Vec2(s.twist(0), s.twist(1)) - v0, s.twist(2)};
  };
  double worst_true = 0.0;
  double worst_seen = 0.0;
  double worst_sensing = 0.0;
  for (const Start& st : starts) {
    for (const double force_deg : {90.0, -90.0, 45.0, 135.0}) {
      const BicyclePlantState s0 =
          Rolling(plant.geometry, st.plate_deg * kDeg, kSpeed * UnitAt(st.travel_deg * kDeg), st.omega_rad_per_s);
      ASSERT_GT(std::abs(WrapAngle(s0.steer_rad[0] - s0.steer_rad[1])), 5.0 * kDeg)
          << "the wheels must not be parallel";
      const Vec2 force = kForce_N * UnitAt((st.travel_deg + force_deg) * kDeg);
      const Vec2 expected = force * kDuration_s / mass;
      const Outcome truth = run(s0, force, false);
      const Outcome seen = run(s0, force, true);
      const double rel_true = (truth.dv - expected).norm() / expected.norm();
      const double rel_seen = (seen.dv - expected).norm() / expected.norm();
      const double rel_sensing = (seen.dv - truth.dv).norm() / expected.norm();
      worst_true = std::max(worst_true, rel_true);
      worst_seen = std::max(worst_seen, rel_seen);
      worst_sensing = std::max(worst_sensing, rel_sensing);
      const std::string what = "plate " + std::to_string(st.plate_deg) + "°, Ω0 " + std::to_string(st.omega_rad_per_s) +
                               " rad/s, force at " + std::to_string(force_deg) + "° to the motion, a point mass of " +
                               std::to_string(mass) + " kg gives Δv (" + std::to_string(expected.x()) + ", " +
                               std::to_string(expected.y()) + ")";
      EXPECT_LT(rel_true, 0.04) << "true state: Δv (" << truth.dv.x() << ", " << truth.dv.y() << "), " << what;
      EXPECT_LT(rel_seen, 0.05) << "encoders: Δv (" << seen.dv.x() << ", " << seen.dv.y() << "), " << what;
      EXPECT_LT(rel_sensing, 0.01) << "the encoders changed Δv by " << rel_sensing << " of F·T/M, " << what;
      // No moment: the plate keeps turning at Ω0.
      EXPECT_NEAR(truth.omega_rad_per_s, s0.twist(2), 0.04 * std::abs(s0.twist(2))) << "true state, " << what;
      EXPECT_NEAR(seen.omega_rad_per_s, s0.twist(2), 0.05 * std::abs(s0.twist(2))) << "encoders, " << what;
    }
  }
  // The free-plate regime: the singularity guard (§2) never acted, so nothing but the caster shaped the motion.
  EXPECT_GT(least_measure, caster.singularity_threshold);
  std::printf(
      "[ numbers  ] worst |Δv − F·T/M|/|F·T/M|: true state %.4f, through the encoders %.4f, encoders vs "
      "true state %.4f; least singularity measure %.3f\n",
      worst_true, worst_seen, worst_sensing, least_measure);
}

// ---------------------------------------------------------------- the bicycle's angular constraint, from the config

TEST(CobotFidelity, BicycleHoldsTheHeadingTheConfigAsksFor) {
  // §2: the bicycle "can implement x, y, and angular constraint". `bicycle.hold_heading_deg` through the backend's
  // reader into the device: the plate starts at θ = 20° at rest and the operator pushes it along x (no moment). The
  // wheels are steered so that the plate turns to θ = 0 as it rolls, and it travels where it is pushed; without the
  // key nothing turns the plate (no moment, no constraint), θ stays at 20°.
  const std::string base =
      "kind: bicycle, initial_heading_deg: 20, operator: {speed_m_per_s: 0.2, direction_deg: 0, max_force_N: 30}";
  for (const bool hold : {true, false}) {
    const std::string yaml =
        "{" + base + (hold ? ", bicycle: {hold_heading_deg: 0, heading_bandwidth_per_s: 3}" : std::string()) + "}";
    BicycleCobotDevice device(std::any_cast<CobotBackendConfig>(ReadSection(yaml, 3)));
    Reading r;
    for (int k = 0; k < 5000; ++k) {
      device.Read(r);
      device.Write(Command::Force(DofVector::Zero(3)));
      device.Update(kPeriod_s);
    }
    const BicyclePlantState& s = device.state();
    const double travel_deg = std::atan2(s.twist(1), s.twist(0)) / kDeg;
    if (hold) {
      EXPECT_NEAR(s.pose.angle_rad / kDeg, 0.0, 1.0) << "the angular constraint did not hold θ = 0";
      EXPECT_NEAR(travel_deg, 0.0, 2.0) << "the plate did not travel where it was pushed";
    } else {
      EXPECT_NEAR(s.pose.angle_rad / kDeg, 20.0, 1.0) << "without the constraint the plate turned";
    }
    EXPECT_GT(std::hypot(s.twist(0), s.twist(1)), 0.15);
  }
}

// ---------------------------------------------------------------- defect 5: the safe state near a fixture

TEST(CobotFidelity, FaultInCasterModeCannotPushThroughAFixture) {
  // The operator pushes at 45° towards the plane y = 0.3 m. At 0.5 s, still in caster mode 0.23 m from it, the
  // device faults (a bad Command from then on, or SetSafe() with no further Command) and the operator keeps pushing.
  // §2: "it is impossible to push the unicycle past a virtual constraint". Locked steering at 45° would run 0.2 m/s
  // straight through it (y ≈ 0.42 m at 3 s). Bound: the normal strike's 5 mm (FixturePlaneIsRenderedAsASteeredWall).
  const Command plane = WithPlane(2, 0.0, 1.0, 0.3);
  Command bad = plane;
  bad.force_N[0] = std::numeric_limits<double>::quiet_NaN();
  for (const bool set_safe : {false, true}) {
    UnicycleCobotDevice device(Pushing(45.0, 0.05));
    Reading r;
    double max_y = 0.0;
    for (int k = 0; k < 3000; ++k) {
      device.Read(r);
      max_y = std::max(max_y, device.rig().state().position_m.y());
      if (k < 500) {
        device.Write(plane);
      } else if (!set_safe) {
        device.Write(bad);
      } else if (k == 500) {
        ASSERT_EQ(device.rig().controller().mode(), WallMode::kCaster);
        device.SetSafe();
      }
      device.Update(kPeriod_s);
    }
    EXPECT_TRUE(device.safe());
    EXPECT_LT(max_y, 0.3 + 0.005) << (set_safe ? "SetSafe()" : "bad Command");
    EXPECT_GT(device.rig().state().position_m.x(), 0.4);  // it slides along the wall instead
  }
  // The bicycle: SetSafe() in caster mode, the plate's reference point stays out of the fixture.
  {
    CobotBackendConfig c = Pushing(45.0, 0.05);
    c.kind = CobotBackendConfig::Kind::kBicycle;
    BicycleCobotDevice device(c);
    const Command plane3 = WithPlane(3, 0.0, 1.0, 0.3);
    Reading r;
    double max_y = 0.0;
    for (int k = 0; k < 3000; ++k) {
      device.Read(r);
      max_y = std::max(max_y, device.state().pose.position_m.y());
      if (k < 500) device.Write(plane3);
      if (k == 500) device.SetSafe();
      device.Update(kPeriod_s);
    }
    EXPECT_LT(max_y, 0.3 + 0.005);
  }
}

TEST(CobotFidelity, SafeStateWithoutAFixtureLocksTheSteering) {
  // No wall to keep: the safe state holds the wheel's heading (Γ = −K₂ω) while the operator pushes elsewhere.
  CobotBackendConfig c = Pushing(0.0, 0.05);
  c.op.then_at_s = 0.2;
  c.op.then_direction_deg = 90.0;
  UnicycleCobotDevice device(c);
  Reading r;
  for (int k = 0; k < 1000; ++k) {
    device.Read(r);
    if (k == 100) device.SetSafe();
    if (k < 100) device.Write(Command::Force(DofVector::Zero(2)));
    device.Update(kPeriod_s);
  }
  EXPECT_NEAR(device.rig().state().heading_rad, 0.0, 2.0 * kDeg);
}

// ---------------------------------------------------------------- item 10: the overlay's geometry

TEST(CobotFidelity, OverlayArcMatchesHandComputedGeometry) {
  // Fig. 8: the arc tangent to the wheel's motion at the wheel and tangent to the wall; r = d/(1 − cos θ).
  const Constraint wall = Constraint::Line({0.0, 0.0}, {1.0, 0.0}, /*forbidden_left=*/true);  // forbidden y > 0
  {
    // d = 50 mm, θ = 60°: r = 0.05/(1 − 0.5) = 0.1 m. The motion (0.5, √3/2); the centre lies along its normal
    // away from the wall, (√3/2, −1/2)·r from the wheel: (0.0866, −0.1); it touches y = 0 at x = 0.0866.
    const Vec2 wheel(0.0, -0.05);
    const OverlayArc arc = ComputeOverlay(wall.Evaluate(wheel), wheel, 60.0 * kDeg);
    ASSERT_TRUE(arc.valid);
    EXPECT_NEAR(arc.radius_m, 0.1, 1e-12);
    EXPECT_NEAR(arc.center_m.x(), 0.1 * std::sqrt(3.0) / 2.0, 1e-12);
    EXPECT_NEAR(arc.center_m.y(), -0.1, 1e-12);
    EXPECT_NEAR(arc.touch_point_m.x(), 0.1 * std::sqrt(3.0) / 2.0, 1e-12);
    EXPECT_NEAR(arc.touch_point_m.y(), 0.0, 1e-12);
  }
  {
    // Mirror: moving left at 150° (θ = 30° to the wall's tangent), d = 20 mm: r = 0.02/(1 − cos 30°) = 0.14928 m;
    // the centre is at the wheel plus r·(−1/2, −√3/2).
    const Vec2 wheel(0.3, -0.02);
    const double r = 0.02 / (1.0 - std::sqrt(3.0) / 2.0);
    const OverlayArc arc = ComputeOverlay(wall.Evaluate(wheel), wheel, 150.0 * kDeg);
    ASSERT_TRUE(arc.valid);
    EXPECT_NEAR(arc.radius_m, r, 1e-12);
    EXPECT_NEAR(arc.center_m.x(), 0.3 - 0.5 * r, 1e-12);
    EXPECT_NEAR(arc.center_m.y(), -0.02 - std::sqrt(3.0) / 2.0 * r, 1e-12);
    EXPECT_NEAR(arc.touch_point_m.y(), 0.0, 1e-12);
  }
  {
    // Head-on (θ = 90°): r = d, the centre d to the side, the arc a quarter circle.
    const Vec2 wheel(0.0, -0.04);
    const OverlayArc arc = ComputeOverlay(wall.Evaluate(wheel), wheel, 90.0 * kDeg);
    ASSERT_TRUE(arc.valid);
    EXPECT_NEAR(arc.radius_m, 0.04, 1e-12);
    EXPECT_NEAR(std::abs(arc.center_m.x()), 0.04, 1e-12);
    EXPECT_NEAR(arc.center_m.y(), -0.04, 1e-12);
  }
  {
    // A tilted wall, the first case rotated by 30° about the origin: the same radius, the centre rotated.
    const double a = 30.0 * kDeg;
    const auto rot = [a](const Vec2& v) {
      return Vec2(std::cos(a) * v.x() - std::sin(a) * v.y(), std::sin(a) * v.x() + std::cos(a) * v.y());
    };
    const Constraint tilted = Constraint::Line({0.0, 0.0}, rot({1.0, 0.0}), true);
    const Vec2 wheel = rot({0.0, -0.05});
    const OverlayArc arc = ComputeOverlay(tilted.Evaluate(wheel), wheel, 60.0 * kDeg + a);
    ASSERT_TRUE(arc.valid);
    EXPECT_NEAR(arc.radius_m, 0.1, 1e-12);
    const Vec2 centre = rot({0.1 * std::sqrt(3.0) / 2.0, -0.1});
    EXPECT_NEAR(arc.center_m.x(), centre.x(), 1e-12);
    EXPECT_NEAR(arc.center_m.y(), centre.y(), 1e-12);
  }
  // Not approaching (θ ≤ 0) or already in the wall: no arc.
  EXPECT_FALSE(ComputeOverlay(wall.Evaluate({0.0, -0.05}), {0.0, -0.05}, -30.0 * kDeg).valid);
  EXPECT_FALSE(ComputeOverlay(wall.Evaluate({0.0, -0.05}), {0.0, -0.05}, 0.0).valid);
  EXPECT_FALSE(ComputeOverlay(wall.Evaluate({0.0, 0.01}), {0.0, 0.01}, 60.0 * kDeg).valid);
}

// ---------------------------------------------------------------- item 8: friction-limited slip

TEST(CobotFidelity, TractionBreaksAtMuTimesNormalLoad) {
  // A wheel at rest, heading +x, pushed straight across (+y) with a slowly rising force. Coulomb friction: no slide
  // while F⊥ ≤ μ·N = 0.5·10 kg·g = 49.03 N, a slide from there on; the slide's acceleration is (F⊥ − μN)/m.
  UnicyclePlantConfig c;
  c.cart_mass_kg = 10.0;
  c.friction_coefficient = 0.5;
  const double limit = 0.5 * 10.0 * kGravity_m_per_s2;
  EXPECT_DOUBLE_EQ(TractionLimit_N(c), limit);
  UnicyclePlantState s;
  double breakaway_N = -1.0;
  for (int k = 0; k < 100000 && breakaway_N < 0.0; ++k) {
    UnicyclePlantInput in;
    in.handle_force_N = {0.0, 1e-3 * k};  // 1 N/s
    Step(c, in, kPeriod_s, s);
    if (s.sliding) breakaway_N = in.handle_force_N.y();
  }
  EXPECT_NEAR(breakaway_N, limit, 2e-3);  // within two force steps
  // Held at μN + 10 N for 0.5 s: v_slip = 10 N / 10 kg · 0.5 s = 0.5 m/s.
  UnicyclePlantState slide = s;
  for (int k = 0; k < 500; ++k) {
    UnicyclePlantInput in;
    in.handle_force_N = {0.0, limit + 10.0};
    Step(c, in, kPeriod_s, slide);
  }
  EXPECT_NEAR(slide.slip_velocity_m_per_s, 0.5, 0.01);
  EXPECT_NEAR(FloorLateralForce_N(c, slide, {0.0, limit + 10.0}), -limit, 1e-9);
  // Let go: friction stops the slide in v/(μg) = 0.102 s, then the wheel holds again.
  for (int k = 0; k < 150; ++k) Step(c, UnicyclePlantInput{}, kPeriod_s, slide);
  EXPECT_FALSE(slide.sliding);
  EXPECT_EQ(slide.slip_velocity_m_per_s, 0.0);
  // μ = 0 (the default) never breaks traction.
  UnicyclePlantConfig ideal;
  UnicyclePlantState t;
  UnicyclePlantInput hard;
  hard.handle_force_N = {0.0, 1e4};
  for (int k = 0; k < 10; ++k) Step(ideal, hard, kPeriod_s, t);
  EXPECT_FALSE(t.sliding);
  EXPECT_EQ(t.position_m.y(), 0.0);
}

}  // namespace
}  // namespace teleop::device::cobot
