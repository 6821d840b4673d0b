// The hybrid backend's key table (hybrid_keys.hpp) against the rig's config structs: each key's default is the
// struct's, an absent key reads as it, and a given one is read in its place.

#include "device/hybrid/hybrid_keys.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <any>
#include <string>

#include "device/hybrid/hybrid_backend.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/error.hpp"

namespace teleop::device::hybrid {
namespace {

HybridDeviceConfig Read(const std::string& yaml) {
  static const std::string file = "hybrid.yaml";
  const YAML::Node node = YAML::Load(yaml);
  const config::Field field(node, "device.hybrid", &file);
  return std::any_cast<HybridDeviceConfig>(FindDevice("hybrid")->read(&field, SectionContext{Role::kMaster, 2}));
}

TEST(HybridKeys, TheTablesDefaultsAreTheStructsAndTheReadersWhenAbsent) {
  const HybridRigConfig code{};
  const HybridRigConfig read = Read("{motor: {}, brake: {}, encoders: {}, force_sensor: {}}").rig;
  const auto same = [](const config::KeySpec& spec, double in_code, double from_yaml) {
    EXPECT_EQ(spec.default_value, in_code) << spec.key;
    EXPECT_EQ(from_yaml, in_code) << spec.key;
  };
  same(keys::kJointInertia, code.joint_inertia_kgm2, read.joint_inertia_kgm2);
  same(keys::kHandleMass, code.handle_mass_kg, read.handle_mass_kg);
  same(keys::kJointDamping, code.joint_damping_Nms_per_rad, read.joint_damping_Nms_per_rad);
  same(keys::kJointCoulomb, code.joint_coulomb_Nm, read.joint_coulomb_Nm);
  same(keys::kSubsteps, code.substeps, read.substeps);
  same(keys::kMotorMaxTorque, code.motor.max_torque_Nm, read.motor.max_torque_Nm);
  same(keys::kMotorTimeConstant, code.motor.time_constant_s, read.motor.time_constant_s);
  same(keys::kMotorPulleyRatio, code.motor.pulley_ratio, read.motor.pulley_ratio);
  same(keys::kBrakeMaxTorque, code.brake.max_torque_Nm, read.brake.max_torque_Nm);
  same(keys::kBrakeTimeConstant, code.brake.time_constant_s, read.brake.time_constant_s);
  same(keys::kBrakeDrag, code.brake.drag_Nm, read.brake.drag_Nm);
  same(keys::kBrakeHysteresis, code.brake.hysteresis_Nm, read.brake.hysteresis_Nm);
  same(keys::kBrakeResidual, code.brake.residual_fraction, read.brake.residual_fraction);
  same(keys::kBrakeStaticRatio, code.brake.static_ratio, read.brake.static_ratio);
  same(keys::kBrakePulleyRatio, code.brake.pulley_ratio, read.brake.pulley_ratio);
  same(keys::kEncoderCounts, code.encoders.counts_per_joint_rev, read.encoders.counts_per_joint_rev);
  same(keys::kEncoderVelocityFilter, code.encoders.velocity_filter_hz, read.encoders.velocity_filter_hz);
  same(keys::kForceSensorNoise, code.force_sensor_dynamics.noise_std_N, read.force_sensor_dynamics.noise_std_N);
  same(keys::kForceSensorBandwidth, code.force_sensor_dynamics.bandwidth_hz, read.force_sensor_dynamics.bandwidth_hz);
  same(keys::kForceSensorSeed, static_cast<double>(code.force_sensor_dynamics.seed),
       static_cast<double>(read.force_sensor_dynamics.seed));
  const AllocationConfig alloc{};
  const AllocationConfig read_alloc = Read("{allocation: {}}").allocation;
  same(keys::kAllocationRestVelocity, alloc.rest_velocity_rad_per_s, read_alloc.rest_velocity_rad_per_s);
  same(keys::kAllocationBrakeMismatch, alloc.brake_model_mismatch, read_alloc.brake_model_mismatch);
  EXPECT_EQ(keys::kAllocationUseBrakes.default_bool, alloc.use_brakes);
  EXPECT_EQ(read_alloc.use_brakes, alloc.use_brakes);
  EXPECT_FALSE(Read("{allocation: {use_brakes: false}}").allocation.use_brakes);
  // 24 + initial_position_m, 11 sections (with fieldbus.force_sensor), 11 geometry, 13 effect, 7 operator,
  // 4 environment, 3 fieldbus, 6 fieldbus.force_sensor
  EXPECT_EQ(keys::All().size(), 80U);
  // The paper's values the docs state (docs/hybrid.md): motor 4.44 N·m after the reducer, brake 4 N·m, pulleys 5.
  EXPECT_EQ(code.motor.max_torque_Nm, 4.44);
  EXPECT_EQ(code.brake.max_torque_Nm, 4.0);
  EXPECT_EQ(code.motor.pulley_ratio, 5.0);
  const HybridRigConfig given = Read("{substeps: 3, motor: {pulley_ratio: 4}, brake: {drag_Nm: 0.2}}").rig;
  EXPECT_EQ(given.substeps, 3);
  EXPECT_EQ(given.motor.pulley_ratio, 4.0);
  EXPECT_EQ(given.brake.drag_Nm, 0.2);
  const ForceSensorDynamicsConfig sensor =
      Read("{force_sensor: {noise_std_N: 0.2, bandwidth_hz: 0, seed: 7}}").rig.force_sensor_dynamics;
  EXPECT_EQ(sensor.noise_std_N, 0.2);
  EXPECT_EQ(sensor.bandwidth_hz, 0.0);
  EXPECT_EQ(sensor.seed, 7U);
}

// rig: the table's default word is the default-constructed config's, absent reads as it, a wrong word is refused
// naming the key and both words.
TEST(HybridKeys, TheRigKeysDefaultIsTheConfigsAndAWrongWordIsRefused) {
  const HybridDeviceConfig code{};
  EXPECT_EQ(keys::kRigKind.default_choice, code.fieldbus_rig ? 1 : 0);
  EXPECT_STREQ(keys::kRigKind.choices[keys::kRigKind.default_choice], "simulated");
  EXPECT_EQ(Read("{}").fieldbus_rig, code.fieldbus_rig);
  EXPECT_FALSE(Read("{rig: simulated}").fieldbus_rig);
  try {
    (void)Read("{rig: real}");
    ADD_FAILURE() << "accepted rig: real";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'device.hybrid.rig': must be simulated or fieldbus, got 'real'"),
              std::string::npos)
        << e.what();
  }
}

std::string ReadError(const std::string& yaml) {
  try {
    (void)Read(yaml);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// geometry, operator, environment and effect: each default is the struct's, an absent key reads as it, a given one
// is read (degrees to radians, pairs, directions normalised), and a key of another effect type is refused.
TEST(HybridKeys, TheSectionsDefaultsAreTheStructsAndGivenValuesAreRead) {
  const FiveBarConfig g{};
  const HybridDeviceConfig absent = Read("{geometry: {}, operator: {}, effect: {type: wall}}");
  EXPECT_EQ(absent.rig.geometry.proximal_1_m, g.proximal_1_m);
  EXPECT_EQ(absent.rig.geometry.base_separation_m, g.base_separation_m);
  EXPECT_NEAR(absent.rig.geometry.joint_1_min_rad, g.joint_1_min_rad, 1e-12);
  EXPECT_NEAR(absent.rig.geometry.joint_2_max_rad, g.joint_2_max_rad, 1e-12);
  EXPECT_EQ(absent.rig.geometry.workspace_y_max_m, g.workspace_y_max_m);
  EXPECT_EQ(absent.rig.initial_position_m, HybridRigConfig{}.initial_position_m);
  const OperatorHandConfig hand{};
  EXPECT_TRUE(absent.simulated_operator);
  EXPECT_EQ(absent.hand.direction, hand.direction);
  EXPECT_EQ(absent.hand.stiffness_N_per_m, hand.stiffness_N_per_m);
  EXPECT_EQ(absent.hand_mass_kg, HybridDeviceConfig{}.hand_mass_kg);
  const WallConfig wall{};
  EXPECT_EQ(absent.effect.kind, HybridEffectConfig::Kind::kWall);
  EXPECT_EQ(absent.effect.wall.kind, wall.kind);
  EXPECT_EQ(absent.effect.wall.stiffness_N_per_m, wall.stiffness_N_per_m);
  EXPECT_EQ(absent.effect.wall.damper_coefficient, wall.damper_coefficient);
  const FrictionConfig friction{};
  const HybridEffectConfig rub = Read("{effect: {type: friction}}").effect;
  EXPECT_EQ(rub.kind, HybridEffectConfig::Kind::kFriction);
  EXPECT_EQ(rub.friction.display, friction.display);
  EXPECT_EQ(rub.friction.stiffness_N_per_m, friction.stiffness_N_per_m);  // not the wall's
  EXPECT_EQ(rub.friction.kinetic_coefficient, friction.kinetic_coefficient);
  EXPECT_NE(keys::kFrictionStiffness.default_value, keys::kWallStiffness.default_value);

  const HybridDeviceConfig given = Read(
      "{geometry: {proximal_1_m: 0.25, joint_1_min_deg: -30, workspace_x_m: [-0.1, 0.1]}, initial_position_m: [0.01, "
      "0.21], operator: {direction: [3, 4], mass_kg: 0.5}, effect: {type: wall, model: popc, normal: [0, 2]}}");
  EXPECT_EQ(given.rig.geometry.proximal_1_m, 0.25);
  EXPECT_NEAR(given.rig.geometry.joint_1_min_rad, -30.0 * config::kDeg, 1e-12);
  EXPECT_EQ(given.rig.geometry.workspace_x_min_m, -0.1);
  EXPECT_EQ(given.rig.geometry.workspace_x_max_m, 0.1);
  EXPECT_EQ(given.rig.initial_position_m, Eigen::Vector2d(0.01, 0.21));
  EXPECT_EQ(given.hand.direction, Eigen::Vector2d(0.6, 0.8));
  EXPECT_EQ(given.hand_mass_kg, 0.5);
  EXPECT_EQ(given.effect.wall.kind, WallKind::kSpringPoPc);
  EXPECT_EQ(given.effect.wall.normal, Eigen::Vector2d(0.0, 1.0));
  const HybridEnvironmentConfig env = Read("{environment: {point_m: [0, 0.3], stiffness_N_per_m: 500}}").environment;
  EXPECT_TRUE(env.wall);
  EXPECT_EQ(env.point_m, Eigen::Vector2d(0.0, 0.3));
  EXPECT_EQ(env.stiffness_N_per_m, 500.0);
  EXPECT_EQ(env.normal, HybridEnvironmentConfig{}.normal);

  EXPECT_NE(ReadError("{effect: {type: none, stiffness_N_per_m: 1}}").find("effect.stiffness_N_per_m"),
            std::string::npos);
  EXPECT_NE(ReadError("{effect: {type: friction, model: popc}}").find("effect.model"), std::string::npos);
  EXPECT_NE(ReadError("{effect: {type: wal}}").find("must be none, wall or friction, got 'wal'"), std::string::npos);
  EXPECT_NE(ReadError("{effect: {type: wall, normal: [0, 0]}}").find("non-zero direction"), std::string::npos);
  EXPECT_NE(ReadError("{environment: {stiffness_N_per_m: 500}}").find("point_m"), std::string::npos);
  EXPECT_NE(ReadError("{geometry: {proximal_1_m: 0}}").find("'device.hybrid.geometry.proximal_1_m'"),
            std::string::npos);
}

TEST(HybridKeys, AnUnknownNestedKeyIsRefusedByItsName) {
  try {
    (void)Read("{brake: {drag_Nm: 0.1, warp_Nm: 1}}");
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("brake.warp_Nm"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace teleop::device::hybrid
