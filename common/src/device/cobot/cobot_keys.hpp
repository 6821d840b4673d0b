#pragma once

// The `device.cobot` keys with a number, a word or true/false, each written once (teleop/config/key_table.hpp): the
// reader (cobot_config_reader.cpp), `--list-devices` and the rows of docs/configuration.md come from this table. Each
// default is the default-constructed CobotBackendConfig's (its member initialisers and
// UnicycleCobotConfig::Prototype()), except steering_time_constant_s, which no struct holds (the reader turns it into
// K2): its default is written here.

#include <array>

#include "device/cobot/cobot_backend.hpp"
#include "teleop/config/key_table.hpp"

namespace teleop::device::cobot::keys {

using config::KeyRange;
using config::KeySpec;
using config::KeyType;

inline const CobotBackendConfig kDefaults{};

// The keys with a word or true/false: each choice lists its words in the order of the enum it sets.
inline const KeySpec kKind{.key = "kind",
                           .type = config::KeyType::kChoice,
                           .meaning = "unicycle (dof 2) or bicycle (dof 3; walls on the plate's reference point).",
                           .choices = {"unicycle", "bicycle"},
                           .default_choice = static_cast<int>(kDefaults.kind)};
inline const KeySpec kGainForm{.key = "gain_form",
                               .type = config::KeyType::kChoice,
                               .meaning = "The tracker's gains: small_angle (eq 8) or circular (eq 7).",
                               .choices = {"small_angle", "circular"},
                               .default_choice = static_cast<int>(kDefaults.unicycle.controller.tracker.gain_form)};
inline const KeySpec kOverlay{.key = "overlay",
                              .type = config::KeyType::kBool,
                              .meaning = "Constraint overlay (§5) on or off.",
                              .default_bool = kDefaults.unicycle.controller.overlay_enabled};
inline const KeySpec kStabilityAction{
    .key = "stability_action",
    .type = config::KeyType::kChoice,
    .meaning = "Above the eq 10 bound: warn, lengthen the look-ahead, or brake (needs brake_max_force_N > 0).",
    .choices = {"warn", "lengthen_lookahead", "brake"},
    .default_choice = static_cast<int>(kDefaults.unicycle.controller.guard.action)};
inline const KeySpec kRig{.key = "rig",
                          .type = config::KeyType::kChoice,
                          .meaning =
                              "simulated (the models above) or fieldbus (the real unicycle cobot on CAN, needs "
                              "fieldbus).",
                          .choices = {"simulated", "fieldbus"},
                          .default_choice = static_cast<int>(kDefaults.rig)};

inline const KeySpec kCartMass{.key = "cart_mass_kg",
                               .unit = "kg",
                               .range = KeyRange::kPositive,
                               .default_value = kDefaults.unicycle.plant.cart_mass_kg,
                               .meaning = "Moving mass."};
inline const KeySpec kRollingDamping{.key = "rolling_damping_Ns_per_m",
                                     .unit = "N·s/m",
                                     .range = KeyRange::kNonNegative,
                                     .default_value = kDefaults.unicycle.plant.rolling_damping_Ns_per_m,
                                     .meaning = "Rolling resistance."};
inline const KeySpec kSteeringInertia{.key = "steering_inertia_kgm2",
                                      .unit = "kg·m²",
                                      .range = KeyRange::kPositive,
                                      .default_value = kDefaults.unicycle.plant.steering_inertia_kgm2,
                                      .meaning = "Wheel assembly about the steering axis."};
inline const KeySpec kSteeringDamping{.key = "steering_damping_Nms_per_rad",
                                      .unit = "N·m·s/rad",
                                      .range = KeyRange::kNonNegative,
                                      .default_value = kDefaults.unicycle.plant.steering_damping_Nms_per_rad,
                                      .meaning = "Steering friction b."};
inline const KeySpec kMaxSteeringTorque{.key = "max_steering_torque_Nm",
                                        .unit = "N·m",
                                        .range = KeyRange::kPositive,
                                        .default_value = kDefaults.unicycle.plant.max_steering_torque_Nm,
                                        .meaning = "Steering motor limit."};
inline const KeySpec kCorneringStiffness{.key = "cornering_stiffness_N_per_rad",
                                         .unit = "N/rad",
                                         .range = KeyRange::kNonNegative,
                                         .default_value = kDefaults.unicycle.plant.cornering_stiffness_N_per_rad,
                                         .meaning = "Wheel slip model C; 0 = no slip."};
inline const KeySpec kBrakeMaxForce{.key = "brake_max_force_N",
                                    .unit = "N",
                                    .range = KeyRange::kNonNegative,
                                    .default_value = kDefaults.unicycle.plant.brake_max_force_N,
                                    .meaning = "Wheel brake; 0 = none."};
inline const KeySpec kFrictionCoefficient{
    .key = "friction_coefficient",
    .range = KeyRange::kNonNegative,
    .default_value = kDefaults.unicycle.plant.friction_coefficient,
    .meaning = "Tire μ: the floor carries at most μ·N across the wheel, then it slides; 0 = no limit."};
inline const KeySpec kNormalLoad{.key = "normal_load_N",
                                 .unit = "N",
                                 .range = KeyRange::kNonNegative,
                                 .default_value = kDefaults.unicycle.plant.normal_load_N,
                                 .meaning = "N of the friction limit; 0 = cart_mass_kg·g."};
inline const KeySpec kWheelRadius{.key = "wheel_radius_m",
                                  .unit = "m",
                                  .range = KeyRange::kPositive,
                                  .default_value = kDefaults.unicycle.sensors.wheel_radius_m,
                                  .meaning = "Wheel radius."};
inline const KeySpec kWheelEncoderCounts{
    .key = "wheel_encoder_counts_per_rev",
    .type = config::KeyType::kInteger,
    .range = KeyRange::kInRange,
    .default_value = static_cast<double>(kDefaults.unicycle.sensors.wheel_encoder_counts_per_rev),
    .meaning = "Wheel encoder counts per revolution; 0 = ideal.",
    .low = 0.0,
    .high = 1e9};
inline const KeySpec kSteeringEncoderCounts{
    .key = "steering_encoder_counts_per_rev",
    .type = config::KeyType::kInteger,
    .range = KeyRange::kInRange,
    .default_value = static_cast<double>(kDefaults.unicycle.sensors.steering_encoder_counts_per_rev),
    .meaning = "Steering encoder counts per revolution; 0 = ideal.",
    .low = 0.0,
    .high = 1e9};
inline const KeySpec kPositionResolution{.key = "position_resolution_m",
                                         .unit = "m",
                                         .range = KeyRange::kNonNegative,
                                         .default_value = kDefaults.unicycle.sensors.position_resolution_m,
                                         .meaning = "Absolute position sensing step; 0 = ideal."};
inline const KeySpec kForceResolution{.key = "force_resolution_N",
                                      .unit = "N",
                                      .range = KeyRange::kNonNegative,
                                      .default_value = kDefaults.unicycle.sensors.force_resolution_N,
                                      .meaning = "Handle force sensor step; 0 = ideal."};
inline const KeySpec kSteeringTimeConstant{.key = "steering_time_constant_s",
                                           .unit = "s",
                                           .range = KeyRange::kPositive,
                                           .default_value = 0.02,
                                           .meaning = "τ of the steering-velocity loop (eq 3c), sets K2 = J/τ − b."};
inline const KeySpec kSpeedFloor{.key = "speed_floor_m_per_s",
                                 .unit = "m/s",
                                 .range = KeyRange::kPositive,
                                 .default_value = kDefaults.unicycle.controller.caster.speed_floor_m_per_s,
                                 .meaning = "ε of eq 2."};
inline const KeySpec kLookahead{.key = "lookahead_m",
                                .unit = "m",
                                .range = KeyRange::kPositive,
                                .default_value = kDefaults.unicycle.controller.tracker.lookahead_m,
                                .meaning = "L of eqs 7-8."};
inline const KeySpec kPGainScale{.key = "p_gain_scale",
                                 .range = KeyRange::kPositive,
                                 .default_value = kDefaults.unicycle.controller.tracker.p_gain_scale,
                                 .meaning = "Multiplies the penetration gain."};
inline const KeySpec kThetaGainScale{.key = "theta_gain_scale",
                                     .range = KeyRange::kPositive,
                                     .default_value = kDefaults.unicycle.controller.tracker.theta_gain_scale,
                                     .meaning = "Multiplies the out-of-tangency gain."};
inline const KeySpec kIntegralGain{.key = "integral_gain_per_m3",
                                   .unit = "1/m³",
                                   .range = KeyRange::kNonNegative,
                                   .default_value = kDefaults.unicycle.controller.tracker.integral_gain_per_m3,
                                   .meaning = "Integral action on p."};
inline const KeySpec kOverlayMinRadius{.key = "overlay_min_radius_m",
                                       .unit = "m",
                                       .range = KeyRange::kNonNegative,
                                       .default_value = kDefaults.unicycle.controller.overlay_min_radius_m,
                                       .meaning = "Overlay activation radius."};
inline const KeySpec kReleaseForce{.key = "release_force_N",
                                   .unit = "N",
                                   .range = KeyRange::kNonNegative,
                                   .default_value = kDefaults.unicycle.controller.release_force_N,
                                   .meaning = "Pull-off force that releases a wall."};
inline const KeySpec kStabilityMargin{.key = "stability_margin",
                                      .range = KeyRange::kInRange,
                                      .default_value = kDefaults.unicycle.controller.guard.margin,
                                      .meaning = "Act at this fraction of the eq 10 speed.",
                                      .low = 0.05,
                                      .high = 1.0};
inline const KeySpec kContactForceThreshold{.key = "contact_force_threshold_N",
                                            .unit = "N",
                                            .range = KeyRange::kPositive,
                                            .default_value = kDefaults.contact_force_threshold_N,
                                            .meaning = "Coupling force that means a blocked slave."};
inline const KeySpec kOperatorSpeed{.key = "operator.speed_m_per_s",
                                    .unit = "m/s",
                                    .range = KeyRange::kPositive,
                                    .default_value = kDefaults.op.speed_m_per_s,
                                    .meaning = "Speed the operator holds."};
inline const KeySpec kOperatorDirection{.key = "operator.direction_deg",
                                        .unit = "deg",
                                        .range = KeyRange::kFinite,
                                        .default_value = kDefaults.op.direction_deg,
                                        .meaning = "Push direction, from +x."};
inline const KeySpec kOperatorThenAt{.key = "operator.then_at_s",
                                     .unit = "s",
                                     .range = KeyRange::kNonNegative,
                                     .default_value = kDefaults.op.then_at_s,
                                     .meaning = "Time of the change of direction; 0 = never."};
inline const KeySpec kOperatorThenDirection{.key = "operator.then_direction_deg",
                                            .unit = "deg",
                                            .range = KeyRange::kFinite,
                                            .default_value = kDefaults.op.then_direction_deg,
                                            .meaning = "Push direction after then_at_s."};
inline const KeySpec kOperatorMaxForce{.key = "operator.max_force_N",
                                       .unit = "N",
                                       .range = KeyRange::kPositive,
                                       .default_value = kDefaults.op.max_force_N,
                                       .meaning = "Largest push."};
inline const KeySpec kHalfWheelbase{.key = "bicycle.half_wheelbase_m",
                                    .unit = "m",
                                    .range = KeyRange::kPositive,
                                    .default_value = kDefaults.bicycle.geometry.half_wheelbase_m,
                                    .meaning = "Wheels at ±this on the plate's x axis."};
inline const KeySpec kPlateMass{.key = "bicycle.plate_mass_kg",
                                .unit = "kg",
                                .range = KeyRange::kPositive,
                                .default_value = kDefaults.bicycle.plate_mass_kg,
                                .meaning = "Plate mass; also the caster's virtual mass (isotropic)."};
inline const KeySpec kPlateInertia{.key = "bicycle.plate_inertia_kgm2",
                                   .unit = "kg·m²",
                                   .range = KeyRange::kPositive,
                                   .default_value = kDefaults.bicycle.plate_inertia_kgm2,
                                   .meaning = "Plate inertia; also the caster's virtual inertia."};
inline const KeySpec kSingularityThreshold{.key = "bicycle.singularity_threshold",
                                           .range = KeyRange::kInRange,
                                           .default_value = kDefaults.bicycle_caster.singularity_threshold,
                                           .meaning = "Singularity measure below which the guard acts.",
                                           .low = 0.0,
                                           .high = 0.99};
inline const KeySpec kSingularityGuard{.key = "bicycle.singularity_guard",
                                       .type = config::KeyType::kBool,
                                       .meaning = "Keep the wheels off the singular configuration.",
                                       .default_bool = kDefaults.bicycle_caster.singularity_guard};
inline const KeySpec kHeadingBandwidth{.key = "bicycle.heading_bandwidth_per_s",
                                       .unit = "rad/s",
                                       .range = KeyRange::kInRange,
                                       .default_value = kDefaults.bicycle_caster.heading_bandwidth_per_s,
                                       .meaning = "ω_h of the angular constraint's return.",
                                       .low = 0.1,
                                       .high = 20.0};

inline const KeySpec kInitialPosition{
    .key = "initial_position_m",
    .type = KeyType::kPair,
    .unit = "m",
    .meaning = "Start position [x, y] (odometry starts here on the fieldbus rig).",
    .default_pair = {kDefaults.initial.position_m.x(), kDefaults.initial.position_m.y()}};
inline const KeySpec kInitialHeading{.key = "initial_heading_deg",
                                     .unit = "°",
                                     .default_value = kDefaults.initial.heading_rad / config::kDeg,
                                     .meaning = "Start heading, from +x."};
inline const KeySpec kOperatorSection{
    .key = "operator",
    .type = KeyType::kSection,
    .meaning =
        "A simulated operator (a master without a human; rig: simulated): the operator.* keys "
        "(`device.cobot.operator`)."};
inline const KeySpec kBicycleSection{
    .key = "bicycle",
    .type = KeyType::kSection,
    .meaning = "The bicycle cobot's plate (kind: bicycle): the bicycle.* keys (`device.cobot.bicycle`)."};
inline const KeySpec kFieldbusSection{
    .key = "fieldbus",
    .type = KeyType::kSection,
    .meaning = "The real rig's CAN bus, steering drive and sensor node (rig: fieldbus; `device.cobot.fieldbus`)."};

// `fieldbus` (rig: fieldbus): its keys with a value, its steering and sensors sections. Not here: the can section
// (the shared CAN reader), the two directions (1 or -1) and the sensor node's COB-IDs (default: from its node id).
inline const CobotFieldbusConfig& kBus = kDefaults.fieldbus;
inline const fieldbus::Cia402DriveConfig& kSteeringDrive = kDefaults.fieldbus.steering.drive;
inline const KeySpec kFieldbusCyclePeriod{
    .key = "fieldbus.cycle_period_ms",
    .unit = "ms",
    .range = KeyRange::kInRange,
    .default_value = kSteeringDrive.cycle_period_s * 1e3,
    .meaning = "SYNC period written to the drive (0x1006); make it 1000 / rate_hz.",
    .low = 0.125,
    .high = 100.0};
inline const KeySpec kFirstFramesTimeout{.key = "fieldbus.first_frames_timeout_ms",
                                         .unit = "ms",
                                         .range = KeyRange::kPositive,
                                         .default_value = kBus.first_frames_timeout_ms,
                                         .meaning = "Activate: wait for the drive's and the sensor node's first PDOs."};
inline const KeySpec kSteeringSection{
    .key = "fieldbus.steering",
    .type = KeyType::kSection,
    .required = true,
    .meaning = "The steering motor's CiA 402 drive: the fieldbus.steering.* keys (`device.cobot.fieldbus.steering`)."};
inline const KeySpec kSensorsSection{
    .key = "fieldbus.sensors",
    .type = KeyType::kSection,
    .required = true,
    .meaning =
        "The wheel encoder, handle force sensor and wheel brake on a separate CAN node: the fieldbus.sensors.* "
        "keys (`device.cobot.fieldbus.sensors`)."};
inline const KeySpec kSteeringNodeId{.key = "fieldbus.steering.node_id",
                                     .type = KeyType::kInteger,
                                     .range = KeyRange::kInRange,
                                     .required = true,
                                     .meaning = "The drive's CANopen node id.",
                                     .low = 1,
                                     .high = 127};
inline const KeySpec kSteeringMode{
    .key = "fieldbus.steering.mode",
    .type = KeyType::kChoice,
    .meaning = "Cyclic synchronous torque: the steering-velocity loop of eq 3c runs on the host (velocity is refused).",
    .choices = {"torque"}};
inline const KeySpec kSteeringGearRatio{.key = "fieldbus.steering.gear_ratio",
                                        .range = KeyRange::kPositive,
                                        .default_value = kBus.steering.gear_ratio,
                                        .meaning = "Motor rad per steering rad."};
inline const KeySpec kSteeringPositionScale{.key = "fieldbus.steering.position_rad_per_count",
                                            .unit = "rad",
                                            .range = KeyRange::kPositive,
                                            .default_value = kSteeringDrive.scaling.position_rad_per_count,
                                            .meaning = "Motor rad per position-actual unit (0x6064)."};
inline const KeySpec kSteeringVelocityScale{.key = "fieldbus.steering.velocity_rad_per_s_per_unit",
                                            .unit = "rad/s",
                                            .range = KeyRange::kPositive,
                                            .default_value = kSteeringDrive.scaling.velocity_rad_per_s_per_unit,
                                            .meaning = "Motor rad/s per velocity-actual unit (0x606C)."};
inline const KeySpec kSteeringRatedTorque{
    .key = "fieldbus.steering.rated_torque_Nm",
    .unit = "N·m",
    .range = KeyRange::kPositive,
    .default_value = kSteeringDrive.scaling.rated_torque_Nm,
    .meaning = "The drive's rated torque 0x6076 (motor side), checked at set-up."};
inline const KeySpec kSteeringMaxTorque{.key = "fieldbus.steering.max_torque_Nm",
                                        .unit = "N·m",
                                        .range = KeyRange::kPositive,
                                        .default_value = kSteeringDrive.max_torque_Nm,
                                        .meaning = "Torque limit written to 0x6072 (motor side)."};
inline const KeySpec kSteeringOffset{.key = "fieldbus.steering.offset_deg",
                                     .unit = "°",
                                     .default_value = kBus.steering_offset_rad / config::kDeg,
                                     .meaning = "The cart's heading when the steering angle reads 0."};
inline const KeySpec kSteeringMaxJump{.key = "fieldbus.steering.max_angle_jump_rad",
                                      .unit = "rad",
                                      .range = KeyRange::kPositive,
                                      .default_value = kBus.steering.max_angle_jump_rad,
                                      .meaning = "Steering angle step per cycle that is an encoder jump."};
inline const KeySpec kSteeringHoldStiffness{.key = "fieldbus.steering.hold_stiffness_Nm_per_rad",
                                            .unit = "N·m/rad",
                                            .range = KeyRange::kPositive,
                                            .default_value = kBus.steering.hold_stiffness_Nm_per_rad,
                                            .meaning = "Hold after an encoder jump (motor side)."};
inline const KeySpec kSteeringHoldDamping{.key = "fieldbus.steering.hold_damping_Nms_per_rad",
                                          .unit = "N·m·s/rad",
                                          .range = KeyRange::kNonNegative,
                                          .default_value = kBus.steering.hold_damping_Nms_per_rad,
                                          .meaning = "Hold damping (motor side)."};
inline const KeySpec kSteeringHeartbeatPeriod{.key = "fieldbus.steering.heartbeat_period_ms",
                                              .unit = "ms",
                                              .range = KeyRange::kInRange,
                                              .default_value = kSteeringDrive.drive_heartbeat_period_ms,
                                              .meaning = "The drive's heartbeat period (0x1017).",
                                              .low = 1.0,
                                              .high = 10000.0};
inline const KeySpec kSteeringHeartbeatTimeout{
    .key = "fieldbus.steering.heartbeat_timeout_ms",
    .unit = "ms",
    .range = KeyRange::kInRange,
    .default_value = kSteeringDrive.heartbeat_timeout_ms,
    .meaning = "The host's consumer of the drive's heartbeat; above heartbeat_period_ms.",
    .low = 1.0,
    .high = 60000.0};
inline const KeySpec kSteeringStale{.key = "fieldbus.steering.stale_after_ms",
                                    .unit = "ms",
                                    .range = KeyRange::kPositive,
                                    .default_value = kSteeringDrive.stale_after_ms,
                                    .meaning = "No TPDO for this long: the drive is lost."};
inline const KeySpec kSteeringDirection{
    .key = "fieldbus.steering.direction",
    .type = KeyType::kInteger,
    .range = KeyRange::kInRange,
    .default_value = kSteeringDrive.scaling.sign,
    .meaning = "1 or -1 (0 is refused): the drive's positive direction against the steering angle's.",
    .low = -1,
    .high = 1};
inline const KeySpec kSensorsSource{
    .key = "fieldbus.sensors.source",
    .type = KeyType::kChoice,
    .meaning = "A separate CAN node (drive is refused: the drive's PDOs carry the steering axis only).",
    .choices = {"node"}};
inline const KeySpec kSensorsNodeId{.key = "fieldbus.sensors.node_id",
                                    .type = KeyType::kInteger,
                                    .range = KeyRange::kInRange,
                                    .required = true,
                                    .meaning = "The sensor node's id, not the drive's nor the host's.",
                                    .low = 1,
                                    .high = 127};
inline const KeySpec kSensorsForceScale{.key = "fieldbus.sensors.force_N_per_unit",
                                        .unit = "N",
                                        .range = KeyRange::kPositive,
                                        .default_value = kBus.sensors.force_N_per_unit,
                                        .meaning = "Handle force per analog unit."};
inline const KeySpec kSensorsStale{.key = "fieldbus.sensors.stale_after_ms",
                                   .unit = "ms",
                                   .range = KeyRange::kPositive,
                                   .default_value = kBus.sensors.stale_after_ms,
                                   .meaning = "No sensor TPDO for this long: the node is lost."};
inline const KeySpec kSensorsMaxWheelStep{.key = "fieldbus.sensors.max_wheel_step_m",
                                          .unit = "m",
                                          .range = KeyRange::kPositive,
                                          .default_value = kBus.sensors.max_wheel_step_m,
                                          .meaning = "Wheel travel step between two TPDOs that is an encoder jump."};
inline const KeySpec kSensorsWheelDirection{.key = "fieldbus.sensors.wheel_direction",
                                            .type = KeyType::kInteger,
                                            .range = KeyRange::kInRange,
                                            .default_value = kBus.sensors.wheel_sign,
                                            .meaning = "1 or -1 (0 is refused): the wheel encoder's count direction.",
                                            .low = -1,
                                            .high = 1};
/// A COB-ID of the sensor node: 0 (the default: CiA 301's pre-defined one from the node id) or 0x081..0x7FF.
constexpr KeySpec SensorCobId(const char* key, double default_value, const char* meaning) {
  return {.key = key,
          .type = KeyType::kInteger,
          .range = KeyRange::kInRange,
          .default_value = default_value,
          .meaning = meaning,
          .low = 0x081,
          .high = 0x7FF};
}
inline const KeySpec kSensorsWheelCobId =
    SensorCobId("fieldbus.sensors.wheel_cob_id", kBus.sensors.wheel_cob_id,
                "Wheel TPDO COB-ID (INTEGER32 counts, CiA 406 0x6004); 0 (absent): 0x180 + node_id.");
inline const KeySpec kSensorsForceCobId = SensorCobId(
    "fieldbus.sensors.force_cob_id", kBus.sensors.force_cob_id,
    "Force TPDO COB-ID (2 x INTEGER16, CiA 401 0x6401/1-2, 0x8000 = invalid); 0 (absent): 0x280 + node_id.");
inline const KeySpec kSensorsBrakeCobId = SensorCobId(
    "fieldbus.sensors.brake_cob_id", kBus.sensors.brake_cob_id,
    "Brake RPDO COB-ID (1 byte, bit 0, CiA 401 0x6200/1), used when brake_max_force_N > 0; 0 (absent): 0x200 + "
    "node_id.");

/// Every key of the table, built at its first use (after static initialisation: its elements are dynamically
/// initialised constants, and a copy made during static initialisation could read one not yet initialised).
inline const auto& All() {
  static const std::array table{kKind,
                                kGainForm,
                                kOverlay,
                                kStabilityAction,
                                kRig,
                                kCartMass,
                                kRollingDamping,
                                kSteeringInertia,
                                kSteeringDamping,
                                kMaxSteeringTorque,
                                kCorneringStiffness,
                                kBrakeMaxForce,
                                kFrictionCoefficient,
                                kNormalLoad,
                                kWheelRadius,
                                kWheelEncoderCounts,
                                kSteeringEncoderCounts,
                                kPositionResolution,
                                kForceResolution,
                                kSteeringTimeConstant,
                                kSpeedFloor,
                                kLookahead,
                                kPGainScale,
                                kThetaGainScale,
                                kIntegralGain,
                                kOverlayMinRadius,
                                kReleaseForce,
                                kStabilityMargin,
                                kContactForceThreshold,
                                kOperatorSpeed,
                                kOperatorDirection,
                                kOperatorThenAt,
                                kOperatorThenDirection,
                                kOperatorMaxForce,
                                kHalfWheelbase,
                                kPlateMass,
                                kPlateInertia,
                                kSingularityThreshold,
                                kHeadingBandwidth,
                                kSingularityGuard,
                                kInitialPosition,
                                kInitialHeading,
                                kOperatorSection,
                                kBicycleSection,
                                kFieldbusSection,
                                kFieldbusCyclePeriod,
                                kFirstFramesTimeout,
                                kSteeringSection,
                                kSensorsSection,
                                kSteeringNodeId,
                                kSteeringMode,
                                kSteeringGearRatio,
                                kSteeringPositionScale,
                                kSteeringVelocityScale,
                                kSteeringRatedTorque,
                                kSteeringMaxTorque,
                                kSteeringOffset,
                                kSteeringMaxJump,
                                kSteeringHoldStiffness,
                                kSteeringHoldDamping,
                                kSteeringHeartbeatPeriod,
                                kSteeringHeartbeatTimeout,
                                kSteeringStale,
                                kSteeringDirection,
                                kSensorsSource,
                                kSensorsNodeId,
                                kSensorsForceScale,
                                kSensorsStale,
                                kSensorsMaxWheelStep,
                                kSensorsWheelDirection,
                                kSensorsWheelCobId,
                                kSensorsForceCobId,
                                kSensorsBrakeCobId};
  return table;
}

}  // namespace teleop::device::cobot::keys
