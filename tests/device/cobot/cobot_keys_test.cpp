// The cobot backend's key table (cobot_keys.hpp) against CobotBackendConfig: each key's default is the default-
// constructed config's, an absent key reads as it, and a given one is read in its place.

#include "device/cobot/cobot_keys.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <any>
#include <numbers>
#include <string>

#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"

namespace teleop::device::cobot {
namespace {

CobotBackendConfig Read(const std::string& yaml, int dof = 2) {
  static const std::string file = "cobot.yaml";
  const YAML::Node node = YAML::Load(yaml);
  const config::Field field(node, "device.cobot", &file);
  return std::any_cast<CobotBackendConfig>(FindDevice("cobot")->read(&field, SectionContext{Role::kMaster, dof}));
}

TEST(CobotKeys, TheTablesDefaultsAreTheConfigsAndTheReadersWhenAbsent) {
  const CobotBackendConfig code{};
  const CobotBackendConfig read = Read("{operator: {}}");
  const CobotBackendConfig bicycle = Read("{kind: bicycle, bicycle: {}}", 3);
  const auto same = [](const config::KeySpec& spec, double in_code, double from_yaml) {
    EXPECT_EQ(spec.default_value, in_code) << spec.key;
    EXPECT_EQ(from_yaml, in_code) << spec.key;
  };
  const UnicyclePlantConfig& p = code.unicycle.plant;
  const UnicyclePlantConfig& rp = read.unicycle.plant;
  same(keys::kCartMass, p.cart_mass_kg, rp.cart_mass_kg);
  same(keys::kRollingDamping, p.rolling_damping_Ns_per_m, rp.rolling_damping_Ns_per_m);
  same(keys::kSteeringInertia, p.steering_inertia_kgm2, rp.steering_inertia_kgm2);
  same(keys::kSteeringDamping, p.steering_damping_Nms_per_rad, rp.steering_damping_Nms_per_rad);
  same(keys::kMaxSteeringTorque, p.max_steering_torque_Nm, rp.max_steering_torque_Nm);
  same(keys::kCorneringStiffness, p.cornering_stiffness_N_per_rad, rp.cornering_stiffness_N_per_rad);
  same(keys::kBrakeMaxForce, p.brake_max_force_N, rp.brake_max_force_N);
  same(keys::kFrictionCoefficient, p.friction_coefficient, rp.friction_coefficient);
  same(keys::kNormalLoad, p.normal_load_N, rp.normal_load_N);
  same(keys::kWheelRadius, code.unicycle.sensors.wheel_radius_m, read.unicycle.sensors.wheel_radius_m);
  same(keys::kWheelEncoderCounts, code.unicycle.sensors.wheel_encoder_counts_per_rev,
       read.unicycle.sensors.wheel_encoder_counts_per_rev);
  same(keys::kSteeringEncoderCounts, code.unicycle.sensors.steering_encoder_counts_per_rev,
       read.unicycle.sensors.steering_encoder_counts_per_rev);
  same(keys::kPositionResolution, code.unicycle.sensors.position_resolution_m,
       read.unicycle.sensors.position_resolution_m);
  same(keys::kForceResolution, code.unicycle.sensors.force_resolution_N, read.unicycle.sensors.force_resolution_N);
  const VirtualWallConfig& w = code.unicycle.controller;
  const VirtualWallConfig& rw = read.unicycle.controller;
  same(keys::kSpeedFloor, w.caster.speed_floor_m_per_s, rw.caster.speed_floor_m_per_s);
  same(keys::kLookahead, w.tracker.lookahead_m, rw.tracker.lookahead_m);
  same(keys::kPGainScale, w.tracker.p_gain_scale, rw.tracker.p_gain_scale);
  same(keys::kThetaGainScale, w.tracker.theta_gain_scale, rw.tracker.theta_gain_scale);
  same(keys::kIntegralGain, w.tracker.integral_gain_per_m3, rw.tracker.integral_gain_per_m3);
  same(keys::kOverlayMinRadius, w.overlay_min_radius_m, rw.overlay_min_radius_m);
  same(keys::kReleaseForce, w.release_force_N, rw.release_force_N);
  same(keys::kStabilityMargin, w.guard.margin, rw.guard.margin);
  same(keys::kContactForceThreshold, code.contact_force_threshold_N, read.contact_force_threshold_N);
  same(keys::kOperatorSpeed, code.op.speed_m_per_s, read.op.speed_m_per_s);
  same(keys::kOperatorDirection, code.op.direction_deg, read.op.direction_deg);
  same(keys::kOperatorThenAt, code.op.then_at_s, read.op.then_at_s);
  same(keys::kOperatorThenDirection, code.op.then_direction_deg, read.op.then_direction_deg);
  same(keys::kOperatorMaxForce, code.op.max_force_N, read.op.max_force_N);
  same(keys::kHalfWheelbase, code.bicycle.geometry.half_wheelbase_m, bicycle.bicycle.geometry.half_wheelbase_m);
  same(keys::kPlateMass, code.bicycle.plate_mass_kg, bicycle.bicycle.plate_mass_kg);
  same(keys::kPlateInertia, code.bicycle.plate_inertia_kgm2, bicycle.bicycle.plate_inertia_kgm2);
  same(keys::kSingularityThreshold, code.bicycle_caster.singularity_threshold,
       bicycle.bicycle_caster.singularity_threshold);
  same(keys::kHeadingBandwidth, code.bicycle_caster.heading_bandwidth_per_s,
       bicycle.bicycle_caster.heading_bandwidth_per_s);
  same(keys::kInitialHeading, code.initial.heading_rad, read.initial.heading_rad);
  EXPECT_EQ(keys::kInitialPosition.default_pair[0], code.initial.position_m.x());
  EXPECT_EQ(keys::kInitialPosition.default_pair[1], code.initial.position_m.y());
  EXPECT_EQ(read.initial.position_m, code.initial.position_m);
  const CobotBackendConfig start = Read("{initial_position_m: [0.1, -0.2], initial_heading_deg: 90}");
  EXPECT_EQ(start.initial.position_m, Vec2(0.1, -0.2));
  EXPECT_NEAR(start.initial.heading_rad, std::numbers::pi / 2.0, 1e-12);
  // 34 with a number, 6 with a word or true/false, initial_position_m and _heading_deg, 3 sections, fieldbus: 2 with
  // a number and 2 sections, steering 15 (its direction included), sensors 9 (wheel direction, 3 COB-IDs)
  EXPECT_EQ(keys::All().size(), 73U);
  const CobotFieldbusConfig bus{};
  EXPECT_EQ(keys::kSteeringMaxTorque.default_value, bus.steering.drive.max_torque_Nm);
  EXPECT_EQ(keys::kSteeringHoldStiffness.default_value, bus.steering.hold_stiffness_Nm_per_rad);
  EXPECT_EQ(keys::kSensorsForceScale.default_value, bus.sensors.force_N_per_unit);
  EXPECT_EQ(keys::kFirstFramesTimeout.default_value, bus.first_frames_timeout_ms);
  // steering_time_constant_s has no struct member: its default τ = 0.02 s sets K2 = J/τ − b (eq 3c).
  EXPECT_EQ(keys::kSteeringTimeConstant.default_value, 0.02);
  EXPECT_NEAR(read.unicycle.controller.caster.k2_Nms_per_rad,
              p.steering_inertia_kgm2 / 0.02 - p.steering_damping_Nms_per_rad, 1e-12);
  const CobotBackendConfig given = Read("{cart_mass_kg: 7, stability_margin: 0.5, operator: {max_force_N: 30}}");
  EXPECT_EQ(given.unicycle.plant.cart_mass_kg, 7.0);
  EXPECT_EQ(given.unicycle.controller.guard.margin, 0.5);
  EXPECT_EQ(given.op.max_force_N, 30.0);
}

// The keys with a word or true/false: the table's default is the default-constructed config's (its enum value's index
// among the words), an absent key reads as it, a given word is read, and a wrong word is refused naming the key and
// the words it allows.
TEST(CobotKeys, TheWordKeysDefaultsAreTheConfigsAndAWrongWordIsRefused) {
  const CobotBackendConfig code{};
  const CobotBackendConfig read = Read("{}");
  const VirtualWallConfig& w = code.unicycle.controller;
  EXPECT_STREQ(keys::kKind.choices[keys::kKind.default_choice], "unicycle");
  EXPECT_EQ(keys::kKind.default_choice, static_cast<int>(code.kind));
  EXPECT_EQ(read.kind, code.kind);
  EXPECT_EQ(keys::kGainForm.default_choice, static_cast<int>(w.tracker.gain_form));
  EXPECT_EQ(read.unicycle.controller.tracker.gain_form, w.tracker.gain_form);
  EXPECT_EQ(keys::kOverlay.default_bool, w.overlay_enabled);
  EXPECT_EQ(read.unicycle.controller.overlay_enabled, w.overlay_enabled);
  EXPECT_EQ(keys::kStabilityAction.default_choice, static_cast<int>(w.guard.action));
  EXPECT_EQ(read.unicycle.controller.guard.action, w.guard.action);
  EXPECT_EQ(keys::kRig.default_choice, static_cast<int>(code.rig));
  EXPECT_EQ(read.rig, code.rig);
  const CobotBackendConfig bicycle = Read("{kind: bicycle, bicycle: {}}", 3);
  EXPECT_EQ(keys::kSingularityGuard.default_bool, code.bicycle_caster.singularity_guard);
  EXPECT_EQ(bicycle.bicycle_caster.singularity_guard, code.bicycle_caster.singularity_guard);
  EXPECT_FALSE(Read("{kind: bicycle, bicycle: {singularity_guard: false}}", 3).bicycle_caster.singularity_guard);
  EXPECT_EQ(config::KeyTableRow(keys::kOverlay),
            "| `overlay` | boolean | true | true, false | " + std::string(keys::kOverlay.meaning) + " |");

  const CobotBackendConfig given = Read(
      "{gain_form: circular, overlay: false, stability_action: lengthen_lookahead, kind: bicycle, bicycle: {}}", 3);
  EXPECT_EQ(given.kind, CobotBackendConfig::Kind::kBicycle);
  EXPECT_EQ(given.unicycle.controller.tracker.gain_form, ConstraintTrackerConfig::GainForm::kCircular);
  EXPECT_FALSE(given.unicycle.controller.overlay_enabled);
  EXPECT_EQ(given.unicycle.controller.guard.action, StabilityGuardConfig::Action::kLengthenLookahead);

  const auto error = [](const std::string& yaml) -> std::string {
    try {
      (void)Read(yaml);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  const std::string action = error("{stability_action: stop}");
  EXPECT_NE(action.find("key 'device.cobot.stability_action': must be warn, lengthen_lookahead or brake, got 'stop'"),
            std::string::npos)
      << action;
  const std::string kind = error("{kind: tricycle}");
  EXPECT_NE(kind.find("'device.cobot.kind': must be unicycle or bicycle, got 'tricycle'"), std::string::npos) << kind;
  const std::string overlay = error("{overlay: maybe}");
  EXPECT_NE(overlay.find("'device.cobot.overlay': expected true or false"), std::string::npos) << overlay;
}

TEST(CobotKeys, AnUnknownNestedKeyIsRefusedByItsName) {
  try {
    (void)Read("{operator: {speed_m_per_s: 0.1, warp_s: 1}}");
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("operator.warp_s"), std::string::npos) << e.what();
  }
}

/// A fieldbus section with `steering` and `sensors` extra keys (flow YAML, without braces) put in.
std::string FieldbusRig(const std::string& steering, const std::string& sensors) {
  return "{rig: fieldbus, fieldbus: {can: {medium: socketcan, interface: vcan0}, steering: {node_id: 5" +
         (steering.empty() ? "" : ", " + steering) + "}, sensors: {node_id: 6" +
         (sensors.empty() ? "" : ", " + sensors) + "}}}";
}

/// The error message of reading `yaml`, or "" when it reads.
std::string ReadError(const std::string& yaml) {
  try {
    (void)Read(yaml);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(CobotKeys, TheDirectionsAndCobIdsAreTableKeysWithTheirDefaultsFromTheNodeId) {
  // Absent: direction 1 and CiA 301's pre-defined COB-IDs from the sensor node's id (6).
  const CobotFieldbusConfig absent = Read(FieldbusRig("", "")).fieldbus;
  EXPECT_EQ(absent.steering.drive.scaling.sign, 1.0);
  EXPECT_EQ(absent.sensors.wheel_sign, 1.0);
  EXPECT_EQ(absent.sensors.WheelCobId(), 0x186u);
  EXPECT_EQ(absent.sensors.ForceCobId(), 0x286u);
  EXPECT_EQ(absent.sensors.BrakeCobId(), 0x206u);
  EXPECT_EQ(keys::kSensorsWheelCobId.default_value, 0.0);
  EXPECT_EQ(keys::kSteeringDirection.default_value, CobotFieldbusConfig{}.steering.drive.scaling.sign);
  // Given: read in their place.
  const CobotFieldbusConfig given = Read(FieldbusRig("direction: -1",
                                                     "wheel_direction: -1, wheel_cob_id: 0x190, force_cob_id: 0x291, "
                                                     "brake_cob_id: 0x212"))
                                        .fieldbus;
  EXPECT_EQ(given.steering.drive.scaling.sign, -1.0);
  EXPECT_EQ(given.sensors.wheel_sign, -1.0);
  EXPECT_EQ(given.sensors.WheelCobId(), 0x190u);
  EXPECT_EQ(given.sensors.ForceCobId(), 0x291u);
  EXPECT_EQ(given.sensors.BrakeCobId(), 0x212u);
  // Refused by name: a direction of 0 or 2, a COB-ID in the NMT/SYNC range or above 11 bits.
  EXPECT_NE(ReadError(FieldbusRig("direction: 0", "")).find("fieldbus.steering.direction': must be 1 or -1"),
            std::string::npos)
      << ReadError(FieldbusRig("direction: 0", ""));
  EXPECT_NE(ReadError(FieldbusRig("", "wheel_direction: 2")).find("wheel_direction"), std::string::npos);
  EXPECT_NE(ReadError(FieldbusRig("", "wheel_cob_id: 0x80")).find("wheel_cob_id"), std::string::npos);
  EXPECT_NE(ReadError(FieldbusRig("", "brake_cob_id: 0x800")).find("brake_cob_id"), std::string::npos);
}

}  // namespace
}  // namespace teleop::device::cobot
