#pragma once

// The `device.hybrid` keys (all but fieldbus.can, fieldbus.drives and fieldbus.modbus), each written once
// (teleop/config/key_table.hpp): the reader (hybrid_backend.cpp), `--list-devices` and the rows of
// docs/configuration.md come from this table; each default is the member initialiser of the rig's config structs
// (hybrid_rig.hpp, motor_model.hpp, particle_brake.hpp, rig_sensing.hpp, five_bar.hpp, wall_model.hpp,
// friction_display.hpp, operator_hand.hpp, hybrid_device.hpp), read from default-constructed structs. A section
// (geometry, effect, ...) is a kSection entry, and the reader's Map of it accepts exactly the table's keys under it
// (config::KeysUnder); effect's keys depend on its type (KeySpec::when).

#include <array>

#include "device/hybrid/hybrid_device.hpp"
#include "device/hybrid/hybrid_rig.hpp"
#include "teleop/config/key_table.hpp"

namespace teleop::device::hybrid::keys {

using config::KeyRange;
using config::KeySpec;
using config::KeyType;

inline const HybridRigConfig kRig{};
inline const HybridDeviceConfig kDevice{};
inline const FiveBarConfig& kGeometry = kRig.geometry;
inline const WallConfig kWall{};
inline const FrictionConfig kFriction{};
inline const OperatorHandConfig kHand{};
inline const HybridEnvironmentConfig kEnvironment{};

/// `rig`: the word's index is HybridDeviceConfig::fieldbus_rig (0 simulated, 1 fieldbus).
inline const KeySpec kRigKind{.key = "rig",
                              .type = KeyType::kChoice,
                              .meaning =
                                  "simulated (the simulated rig) or fieldbus (the real rig: device.hybrid.fieldbus, "
                                  "required).",
                              .choices = {"simulated", "fieldbus"},
                              .default_choice = HybridDeviceConfig{}.fieldbus_rig ? 1 : 0};

inline const KeySpec kJointInertia{.key = "joint_inertia_kgm2",
                                   .unit = "kg·m²",
                                   .range = KeyRange::kPositive,
                                   .default_value = kRig.joint_inertia_kgm2,
                                   .meaning = "Reflected actuator + pulley inertia per joint."};
inline const KeySpec kHandleMass{.key = "handle_mass_kg",
                                 .unit = "kg",
                                 .range = KeyRange::kNonNegative,
                                 .default_value = kRig.handle_mass_kg,
                                 .meaning = "Point mass at the handle."};
inline const KeySpec kJointDamping{.key = "joint_damping_Nms_per_rad",
                                   .unit = "N·m·s/rad",
                                   .range = KeyRange::kNonNegative,
                                   .default_value = kRig.joint_damping_Nms_per_rad,
                                   .meaning = "Viscous friction per joint (bearings and tendons)."};
inline const KeySpec kJointCoulomb{.key = "joint_coulomb_Nm",
                                   .unit = "N·m",
                                   .range = KeyRange::kNonNegative,
                                   .default_value = kRig.joint_coulomb_Nm,
                                   .meaning = "Coulomb friction per joint, joint side."};
inline const KeySpec kSubsteps{.key = "substeps",
                               .type = KeyType::kInteger,
                               .range = KeyRange::kInRange,
                               .default_value = static_cast<double>(kRig.substeps),
                               .meaning = "Integration sub-steps per period.",
                               .low = 1,
                               .high = 1000};

inline const KeySpec kInitialPosition{
    .key = "initial_position_m",
    .type = KeyType::kPair,
    .unit = "m",
    .meaning = "Handle start [x, y] in the base frame; readings are relative to it (and the fieldbus rig's origin).",
    .default_pair = {kRig.initial_position_m.x(), kRig.initial_position_m.y()}};

// The sections: a mapping each, its keys below.
inline const KeySpec kGeometrySection{.key = "geometry",
                                      .type = KeyType::kSection,
                                      .meaning = "The five-bar: the geometry.* keys (`device.hybrid.geometry`)."};
inline const KeySpec kMotorSection{.key = "motor",
                                   .type = KeyType::kSection,
                                   .meaning = "The motor per joint: the motor.* keys (`device.hybrid.motor`)."};
inline const KeySpec kBrakeSection{
    .key = "brake",
    .type = KeyType::kSection,
    .meaning = "The particle brake per joint: the brake.* keys (`device.hybrid.brake`)."};
inline const KeySpec kEncodersSection{
    .key = "encoders",
    .type = KeyType::kSection,
    .meaning = "The simulated rig's encoders: the encoders.* keys (`device.hybrid.encoders`)."};
inline const KeySpec kForceSensorSection{
    .key = "force_sensor",
    .type = KeyType::kSection,
    .meaning = "The simulated handle sensor: the force_sensor.* keys (`device.hybrid.force_sensor`)."};
inline const KeySpec kAllocationSection{
    .key = "allocation",
    .type = KeyType::kSection,
    .meaning = "The motor/brake torque allocation: the allocation.* keys (`device.hybrid.allocation`)."};
inline const KeySpec kEffectSection{
    .key = "effect",
    .type = KeyType::kSection,
    .meaning = "A local haptic effect of the simulated rig: the effect.* keys (`device.hybrid.effect`); absent: none."};
inline const KeySpec kOperatorSection{
    .key = "operator",
    .type = KeyType::kSection,
    .meaning =
        "The simulated hand pushing the handle (master): the operator.* keys (`device.hybrid.operator`); absent: "
        "none."};
inline const KeySpec kEnvironmentSection{
    .key = "environment",
    .type = KeyType::kSection,
    .meaning =
        "A simulated wall touching the handle (slave): the environment.* keys (`device.hybrid.environment`); absent: "
        "free space."};
inline const KeySpec kFieldbusSection{
    .key = "fieldbus",
    .type = KeyType::kSection,
    .meaning = "The real rig's buses, read only with rig: fieldbus (`device.hybrid.fieldbus`)."};

inline const KeySpec kProximal1{.key = "geometry.proximal_1_m",
                                .unit = "m",
                                .range = KeyRange::kPositive,
                                .default_value = kGeometry.proximal_1_m,
                                .meaning = "Proximal link of joint 1."};
inline const KeySpec kProximal2{.key = "geometry.proximal_2_m",
                                .unit = "m",
                                .range = KeyRange::kPositive,
                                .default_value = kGeometry.proximal_2_m,
                                .meaning = "Proximal link of joint 2."};
inline const KeySpec kDistal1{.key = "geometry.distal_1_m",
                              .unit = "m",
                              .range = KeyRange::kPositive,
                              .default_value = kGeometry.distal_1_m,
                              .meaning = "Distal link on joint 1's side."};
inline const KeySpec kDistal2{.key = "geometry.distal_2_m",
                              .unit = "m",
                              .range = KeyRange::kPositive,
                              .default_value = kGeometry.distal_2_m,
                              .meaning = "Distal link on joint 2's side."};
inline const KeySpec kBaseSeparation{.key = "geometry.base_separation_m",
                                     .unit = "m",
                                     .range = KeyRange::kNonNegative,
                                     .default_value = kGeometry.base_separation_m,
                                     .meaning = "Distance between the two base joints."};
inline const KeySpec kJoint1Min{.key = "geometry.joint_1_min_deg",
                                .unit = "°",
                                .default_value = kGeometry.joint_1_min_rad / config::kDeg,
                                .meaning = "Joint 1's lower limit."};
inline const KeySpec kJoint1Max{.key = "geometry.joint_1_max_deg",
                                .unit = "°",
                                .default_value = kGeometry.joint_1_max_rad / config::kDeg,
                                .meaning = "Joint 1's upper limit."};
inline const KeySpec kJoint2Min{.key = "geometry.joint_2_min_deg",
                                .unit = "°",
                                .default_value = kGeometry.joint_2_min_rad / config::kDeg,
                                .meaning = "Joint 2's lower limit."};
inline const KeySpec kJoint2Max{.key = "geometry.joint_2_max_deg",
                                .unit = "°",
                                .default_value = kGeometry.joint_2_max_rad / config::kDeg,
                                .meaning = "Joint 2's upper limit."};
inline const KeySpec kWorkspaceX{.key = "geometry.workspace_x_m",
                                 .type = KeyType::kPair,
                                 .unit = "m",
                                 .meaning = "The design workspace's [min, max] x, base frame.",
                                 .default_pair = {kGeometry.workspace_x_min_m, kGeometry.workspace_x_max_m}};
inline const KeySpec kWorkspaceY{.key = "geometry.workspace_y_m",
                                 .type = KeyType::kPair,
                                 .unit = "m",
                                 .meaning = "The design workspace's [min, max] y, base frame.",
                                 .default_pair = {kGeometry.workspace_y_min_m, kGeometry.workspace_y_max_m}};

/// `effect.type`: the word's index is HybridEffectConfig::Kind.
inline const KeySpec kEffectType{.key = "effect.type",
                                 .type = KeyType::kChoice,
                                 .required = true,
                                 .meaning = "none, a wall, or a friction surface; each takes only its own keys.",
                                 .choices = {"none", "wall", "friction"}};
/// `effect.model` (wall): the word's index is WallKind.
inline const KeySpec kWallModel{.key = "effect.model",
                                .type = KeyType::kChoice,
                                .meaning = "The wall's rendering (docs/hybrid.md).",
                                .choices = {"spring", "popc", "hybrid", "linear-damper"},
                                .default_choice = static_cast<int>(kWall.kind),
                                .when = "wall"};
inline const KeySpec kWallPoint{.key = "effect.point_m",
                                .type = KeyType::kPair,
                                .unit = "m",
                                .meaning = "A point of the wall's surface, base frame.",
                                .default_pair = {kWall.point_m.x(), kWall.point_m.y()},
                                .when = "wall"};
inline const KeySpec kWallNormal{.key = "effect.normal",
                                 .type = KeyType::kPair,
                                 .meaning = "The surface normal, into free space (normalised; not zero).",
                                 .default_pair = {kWall.normal.x(), kWall.normal.y()},
                                 .when = "wall"};
inline const KeySpec kWallStiffness{.key = "effect.stiffness_N_per_m",
                                    .unit = "N/m",
                                    .range = KeyRange::kNonNegative,
                                    .default_value = kWall.stiffness_N_per_m,
                                    .meaning = "Wall stiffness.",
                                    .when = "wall"};
inline const KeySpec kWallDamper{.key = "effect.damper_coefficient",
                                 .unit = "N·s³/m³",
                                 .range = KeyRange::kNonNegative,
                                 .default_value = kWall.damper_coefficient,
                                 .meaning = "The cubic damper's coefficient.",
                                 .when = "wall"};
inline const KeySpec kWallMaxForce{.key = "effect.max_force_N",
                                   .unit = "N",
                                   .range = KeyRange::kPositive,
                                   .default_value = kWall.max_force_N,
                                   .meaning = "The wall's force limit.",
                                   .when = "wall"};
/// `effect.display` (friction): the word's index is FrictionDisplay.
inline const KeySpec kFrictionDisplay{.key = "effect.display",
                                      .type = KeyType::kChoice,
                                      .meaning = "Who renders the friction: the motors or the brakes.",
                                      .choices = {"motor", "brake"},
                                      .default_choice = static_cast<int>(kFriction.display),
                                      .when = "friction"};
inline const KeySpec kFrictionPoint{.key = "effect.point_m",
                                    .type = KeyType::kPair,
                                    .unit = "m",
                                    .meaning = "A point of the surface, base frame.",
                                    .default_pair = {kFriction.point_m.x(), kFriction.point_m.y()},
                                    .when = "friction"};
inline const KeySpec kFrictionNormal{.key = "effect.normal",
                                     .type = KeyType::kPair,
                                     .meaning = "The surface normal, into free space (normalised; not zero).",
                                     .default_pair = {kFriction.normal.x(), kFriction.normal.y()},
                                     .when = "friction"};
inline const KeySpec kFrictionStiffness{.key = "effect.stiffness_N_per_m",
                                        .unit = "N/m",
                                        .range = KeyRange::kNonNegative,
                                        .default_value = kFriction.stiffness_N_per_m,
                                        .meaning = "The surface's normal stiffness.",
                                        .when = "friction"};
inline const KeySpec kFrictionStatic{.key = "effect.static_coefficient",
                                     .range = KeyRange::kNonNegative,
                                     .default_value = kFriction.static_coefficient,
                                     .meaning = "Static friction coefficient.",
                                     .when = "friction"};
inline const KeySpec kFrictionKinetic{.key = "effect.kinetic_coefficient",
                                      .range = KeyRange::kNonNegative,
                                      .default_value = kFriction.kinetic_coefficient,
                                      .meaning = "Kinetic friction coefficient; at most static_coefficient.",
                                      .when = "friction"};

inline const KeySpec kHandDirection{.key = "operator.direction",
                                    .type = KeyType::kPair,
                                    .meaning = "The hand's direction of travel, base frame (normalised; not zero).",
                                    .default_pair = {kHand.direction.x(), kHand.direction.y()}};
inline const KeySpec kHandSpeed{.key = "operator.speed_m_per_s",
                                .unit = "m/s",
                                .range = KeyRange::kNonNegative,
                                .default_value = kHand.speed_m_per_s,
                                .meaning = "The hand's target speed."};
inline const KeySpec kHandTravel{.key = "operator.travel_m",
                                 .unit = "m",
                                 .range = KeyRange::kNonNegative,
                                 .default_value = kHand.travel_m,
                                 .meaning = "How far the target moves from the start."};
inline const KeySpec kHandStiffness{.key = "operator.stiffness_N_per_m",
                                    .unit = "N/m",
                                    .range = KeyRange::kNonNegative,
                                    .default_value = kHand.stiffness_N_per_m,
                                    .meaning = "The hand's grip stiffness towards its target."};
inline const KeySpec kHandDamping{.key = "operator.damping_Ns_per_m",
                                  .unit = "N·s/m",
                                  .range = KeyRange::kNonNegative,
                                  .default_value = kHand.damping_Ns_per_m,
                                  .meaning = "The hand's grip damping."};
inline const KeySpec kHandMaxForce{.key = "operator.max_force_N",
                                   .unit = "N",
                                   .range = KeyRange::kNonNegative,
                                   .default_value = kHand.max_force_N,
                                   .meaning = "The hand's force limit."};
inline const KeySpec kHandMass{.key = "operator.mass_kg",
                               .unit = "kg",
                               .range = KeyRange::kNonNegative,
                               .default_value = kDevice.hand_mass_kg,
                               .meaning = "The hand's mass, added to the handle's."};

inline const KeySpec kEnvironmentPoint{.key = "environment.point_m",
                                       .type = KeyType::kPair,
                                       .unit = "m",
                                       .required = true,
                                       .meaning = "A point of the wall's surface, base frame."};
inline const KeySpec kEnvironmentNormal{
    .key = "environment.normal",
    .type = KeyType::kPair,
    .meaning = "The wall's normal, into free space (normalised; not zero); it occupies (p − point)·n ≥ 0.",
    .default_pair = {kEnvironment.normal.x(), kEnvironment.normal.y()}};
inline const KeySpec kEnvironmentStiffness{.key = "environment.stiffness_N_per_m",
                                           .unit = "N/m",
                                           .range = KeyRange::kPositive,
                                           .required = true,
                                           .meaning = "Wall stiffness (it only pushes)."};
inline const KeySpec kEnvironmentDamping{.key = "environment.damping_Ns_per_m",
                                         .unit = "N·s/m",
                                         .range = KeyRange::kNonNegative,
                                         .default_value = kEnvironment.damping_Ns_per_m,
                                         .meaning = "Wall damping (only while in contact)."};

inline const KeySpec kMotorMaxTorque{.key = "motor.max_torque_Nm",
                                     .unit = "N·m",
                                     .range = KeyRange::kPositive,
                                     .default_value = kRig.motor.max_torque_Nm,
                                     .meaning = "Motor torque limit after the reducer (pulley 1 axis)."};
inline const KeySpec kMotorTimeConstant{
    .key = "motor.time_constant_s",
    .unit = "s",
    .range = KeyRange::kNonNegative,
    .default_value = kRig.motor.time_constant_s,
    .meaning =
        "Current-loop (torque) lag of the delivered torque; the paper's 7 ms is the mechanical time "
        "constant; 0 = none."};
inline const KeySpec kMotorPulleyRatio{.key = "motor.pulley_ratio",
                                       .range = KeyRange::kPositive,
                                       .default_value = kRig.motor.pulley_ratio,
                                       .meaning = "Joint torque = pulley_ratio × motor torque."};

inline const KeySpec kBrakeMaxTorque{.key = "brake.max_torque_Nm",
                                     .unit = "N·m",
                                     .range = KeyRange::kPositive,
                                     .default_value = kRig.brake.max_torque_Nm,
                                     .meaning = "Brake capacity at the brake shaft."};
inline const KeySpec kBrakeTimeConstant{.key = "brake.time_constant_s",
                                        .unit = "s",
                                        .range = KeyRange::kNonNegative,
                                        .default_value = kRig.brake.time_constant_s,
                                        .meaning = "First-order lag of the capacity; 0 = none."};
inline const KeySpec kBrakeDrag{.key = "brake.drag_Nm",
                                .unit = "N·m",
                                .range = KeyRange::kNonNegative,
                                .default_value = kRig.brake.drag_Nm,
                                .meaning = "Unpowered drag torque at the shaft."};
inline const KeySpec kBrakeHysteresis{.key = "brake.hysteresis_Nm",
                                      .unit = "N·m",
                                      .range = KeyRange::kNonNegative,
                                      .default_value = kRig.brake.hysteresis_Nm,
                                      .meaning =
                                          "The delivered torque stays until the command has moved this much; "
                                          "0 = none."};
inline const KeySpec kBrakeResidual{
    .key = "brake.residual_fraction",
    .range = KeyRange::kInRange,
    .default_value = kRig.brake.residual_fraction,
    .meaning = "Remanence after release, a fraction of the largest torque delivered; 0 = none.",
    .low = 0.0,
    .high = 1.0};
inline const KeySpec kBrakeStaticRatio{.key = "brake.static_ratio",
                                       .range = KeyRange::kInRange,
                                       .default_value = kRig.brake.static_ratio,
                                       .meaning = "Static / sliding torque; 1 = none.",
                                       .low = 1.0,
                                       .high = 10.0};
inline const KeySpec kBrakePulleyRatio{.key = "brake.pulley_ratio",
                                       .range = KeyRange::kPositive,
                                       .default_value = kRig.brake.pulley_ratio,
                                       .meaning = "Joint torque = pulley_ratio × brake torque."};

inline const KeySpec kEncoderCounts{.key = "encoders.counts_per_joint_rev",
                                    .range = KeyRange::kNonNegative,
                                    .default_value = kRig.encoders.counts_per_joint_rev,
                                    .meaning = "The simulated rig's encoder counts per joint revolution; 0 = exact."};
inline const KeySpec kEncoderVelocityFilter{.key = "encoders.velocity_filter_hz",
                                            .unit = "Hz",
                                            .range = KeyRange::kNonNegative,
                                            .default_value = kRig.encoders.velocity_filter_hz,
                                            .meaning = "Low-pass of the differenced velocity; 0 = none."};

inline const KeySpec kForceSensorNoise{.key = "force_sensor.noise_std_N",
                                       .unit = "N",
                                       .range = KeyRange::kNonNegative,
                                       .default_value = kRig.force_sensor_dynamics.noise_std_N,
                                       .meaning = "The simulated handle sensor's white noise per axis; 0 = none."};
inline const KeySpec kForceSensorBandwidth{.key = "force_sensor.bandwidth_hz",
                                           .unit = "Hz",
                                           .range = KeyRange::kNonNegative,
                                           .default_value = kRig.force_sensor_dynamics.bandwidth_hz,
                                           .meaning = "The simulated handle sensor's first-order bandwidth; 0 = none."};
inline const KeySpec kForceSensorSeed{.key = "force_sensor.seed",
                                      .type = KeyType::kInteger,
                                      .range = KeyRange::kInRange,
                                      .default_value = static_cast<double>(kRig.force_sensor_dynamics.seed),
                                      .meaning =
                                          "Seed of the simulated handle sensor's noise (the same seed, the same "
                                          "readings).",
                                      .low = 0,
                                      .high = 2147483647};

inline const AllocationConfig kAllocation{};
inline const KeySpec kAllocationUseBrakes{.key = "allocation.use_brakes",
                                          .type = KeyType::kBool,
                                          .meaning = "false: motors only (the active system the paper compares with).",
                                          .default_bool = kAllocation.use_brakes};
inline const KeySpec kAllocationRestVelocity{
    .key = "allocation.rest_velocity_rad_per_s",
    .unit = "rad/s",
    .range = KeyRange::kNonNegative,
    .default_value = kAllocation.rest_velocity_rad_per_s,
    .meaning = "Below this joint speed a brake opposes the operator's torque instead of the motion."};
inline const KeySpec kAllocationBrakeMismatch{
    .key = "allocation.brake_model_mismatch",
    .range = KeyRange::kNonNegative,
    .default_value = kAllocation.brake_model_mismatch,
    .meaning =
        "The simulated rig's allocation believes its brake faster by this fraction and stronger by half of it (0.2: "
        "20 % faster, 10 % stronger); at most 0.9, checked at start."};

// `fieldbus` (rig: fieldbus): its keys with a value and its force_sensor section (the can bus section, the drives
// list and the modbus section are read apart, hybrid_fieldbus_section.cpp).
inline const HybridFieldbusConfig kFieldbus{};
inline const fieldbus::CanForceSensorConfig kCanSensor{};
inline const KeySpec kFieldbusCyclePeriod{.key = "fieldbus.cycle_period_ms",
                                          .unit = "ms",
                                          .range = KeyRange::kInRange,
                                          .default_value = fieldbus::Cia402DriveConfig{}.cycle_period_s * 1e3,
                                          .meaning = "Written to the drives' 0x1006; make it 1000 / rate_hz.",
                                          .low = 0.1,
                                          .high = 100.0};
inline const KeySpec kFieldbusSyncCobId{
    .key = "fieldbus.sync_cob_id",
    .type = KeyType::kInteger,
    .range = KeyRange::kInRange,
    .default_value = static_cast<double>(kFieldbus.sync_cob_id),
    .meaning =
        "The one SYNC per cycle the device sends in its bus exchange, after draining the previous SYNC's "
        "TPDOs: every SYNC follows both drives' RPDOs of the previous cycle, so both apply their torque on it.",
    .low = 1,
    .high = 0x7FF};
inline const KeySpec kFieldbusActivateTimeout{
    .key = "fieldbus.activate_timeout_ms",
    .unit = "ms",
    .range = KeyRange::kInRange,
    .default_value = kFieldbus.activate_timeout_ms,
    .meaning =
        "At Activate: wait for the amplifier's first poll, and SYNCs until both drives and the CAN sensor "
        "answer.",
    .low = 1.0,
    .high = 3600e3};
inline const KeySpec kFieldbusForceSensorSection{
    .key = "fieldbus.force_sensor",
    .type = KeyType::kSection,
    .required = true,
    .meaning = "The handle force sensor: the fieldbus.force_sensor.* keys (`device.hybrid.fieldbus.force_sensor`)."};
/// `fieldbus.force_sensor.bus`: the word's index is ForceSensorBus.
inline const KeySpec kForceSensorBus{
    .key = "fieldbus.force_sensor.bus",
    .type = KeyType::kChoice,
    .required = true,
    .meaning =
        "Where the handle sensor is read: the amplifier's inputs force_x_N, force_y_N (no other key), or a "
        "CAN node on the drives' bus.",
    .choices = {"modbus", "can"}};
inline const KeySpec kCanSensorCobId{
    .key = "fieldbus.force_sensor.cob_id",
    .type = KeyType::kInteger,
    .range = KeyRange::kInRange,
    .required = true,
    .meaning = "The sensor's frame: F_x, F_y little-endian, TPDO-style (fieldbus/can_force_sensor.hpp); not 0x080.",
    .low = 1,
    .high = 0x7FF,
    .when = "can"};
/// `fieldbus.force_sensor.encoding`: the word's index is fieldbus::ForceSensorEncoding.
inline const KeySpec kCanSensorEncoding{
    .key = "fieldbus.force_sensor.encoding",
    .type = KeyType::kChoice,
    .meaning = "Per axis; the most negative value reads as NaN (overload/error: kFaultNonFiniteSensor).",
    .choices = {"int16", "int32"},
    .default_choice = static_cast<int>(kCanSensor.encoding),
    .when = "can"};
inline const KeySpec kCanSensorScale{.key = "fieldbus.force_sensor.scale_N_per_count",
                                     .unit = "N",
                                     .required = true,
                                     .meaning = "N per raw count; not 0 (negative flips both axes).",
                                     .when = "can"};
inline const KeySpec kCanSensorOffset{.key = "fieldbus.force_sensor.offset_N",
                                      .type = KeyType::kPair,
                                      .unit = "N",
                                      .meaning = "N at raw 0 (bias), [x, y].",
                                      .default_pair = {kCanSensor.offset_N[0], kCanSensor.offset_N[1]},
                                      .when = "can"};
inline const KeySpec kCanSensorStale{.key = "fieldbus.force_sensor.stale_after_ms",
                                     .unit = "ms",
                                     .range = KeyRange::kPositive,
                                     .default_value = kCanSensor.stale_after_ms,
                                     .meaning = "No frame for this long: the safe state.",
                                     .when = "can"};

/// Every key of the table, built at its first use (after static initialisation: its elements are dynamically
/// initialised constants, and a copy made during static initialisation could read one not yet initialised).
inline const auto& All() {
  static const std::array table{kRigKind,
                                kInitialPosition,
                                kJointInertia,
                                kHandleMass,
                                kJointDamping,
                                kJointCoulomb,
                                kSubsteps,
                                kMotorMaxTorque,
                                kMotorTimeConstant,
                                kMotorPulleyRatio,
                                kBrakeMaxTorque,
                                kBrakeTimeConstant,
                                kBrakeDrag,
                                kBrakeHysteresis,
                                kBrakeResidual,
                                kBrakeStaticRatio,
                                kBrakePulleyRatio,
                                kEncoderCounts,
                                kEncoderVelocityFilter,
                                kForceSensorNoise,
                                kForceSensorBandwidth,
                                kForceSensorSeed,
                                kAllocationUseBrakes,
                                kAllocationRestVelocity,
                                kAllocationBrakeMismatch,
                                kGeometrySection,
                                kProximal1,
                                kProximal2,
                                kDistal1,
                                kDistal2,
                                kBaseSeparation,
                                kJoint1Min,
                                kJoint1Max,
                                kJoint2Min,
                                kJoint2Max,
                                kWorkspaceX,
                                kWorkspaceY,
                                kMotorSection,
                                kBrakeSection,
                                kEncodersSection,
                                kForceSensorSection,
                                kAllocationSection,
                                kEffectSection,
                                kEffectType,
                                kWallModel,
                                kWallPoint,
                                kWallNormal,
                                kWallStiffness,
                                kWallDamper,
                                kWallMaxForce,
                                kFrictionDisplay,
                                kFrictionPoint,
                                kFrictionNormal,
                                kFrictionStiffness,
                                kFrictionStatic,
                                kFrictionKinetic,
                                kOperatorSection,
                                kHandDirection,
                                kHandSpeed,
                                kHandTravel,
                                kHandStiffness,
                                kHandDamping,
                                kHandMaxForce,
                                kHandMass,
                                kEnvironmentSection,
                                kEnvironmentPoint,
                                kEnvironmentNormal,
                                kEnvironmentStiffness,
                                kEnvironmentDamping,
                                kFieldbusSection,
                                kFieldbusCyclePeriod,
                                kFieldbusSyncCobId,
                                kFieldbusActivateTimeout,
                                kFieldbusForceSensorSection,
                                kForceSensorBus,
                                kCanSensorCobId,
                                kCanSensorEncoding,
                                kCanSensorScale,
                                kCanSensorOffset,
                                kCanSensorStale};
  return table;
}

}  // namespace teleop::device::hybrid::keys
