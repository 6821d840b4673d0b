#pragma once

// The `device.arm` keys with a value, each written once (teleop/config/key_table.hpp): the reader (arm_backend.cpp),
// `--list-devices` and the rows of docs/configuration.md come from this table. An optional key's default is its
// config struct's member initialiser.

#include <array>

#include "arm_device.hpp"
#include "arm_section.hpp"
#include "simulated_arm.hpp"
#include "teleop/config/key_table.hpp"

namespace teleop::device::arm::arm_keys {

using config::KeyRange;
using config::KeySpec;
using config::KeyType;

inline const KeySpec kUrdf = [] {
  KeySpec s{"urdf",
            KeyType::kText,
            "",
            KeyRange::kFinite,
            true,
            0.0,
            "The arm's URDF file; a relative path is beside this config file."};
  return s;
}();
inline const KeySpec kBaseLink = [] {
  KeySpec s{"base_link",
            KeyType::kText,
            "",
            KeyRange::kFinite,
            true,
            0.0,
            "The URDF link whose frame is the device's base frame B."};
  return s;
}();
inline const KeySpec kToolLink = [] {
  KeySpec s{"tool_link",
            KeyType::kText,
            "",
            KeyRange::kFinite,
            true,
            0.0,
            "The URDF link that carries the tool (downstream of base_link)."};
  return s;
}();
inline const KeySpec kToolOffset = [] {
  KeySpec s{"tool_offset_m",
            KeyType::kDofValue,
            "m",
            KeyRange::kFinite,
            false,
            0.0,
            "The tool point in the tool link's frame (x, y, z)."};
  return s;
}();
inline const KeySpec kWorkspaceOrigin = [] {
  KeySpec s{"workspace_origin_m",
            KeyType::kDofValue,
            "m",
            KeyRange::kFinite,
            false,
            0.0,
            "The point of the base frame the device reports as its position zero: position = p_BT - origin (x, y, z), "
            "so that two arms of different sizes couple around their working points."};
  return s;
}();
inline const KeySpec kGravity = [] {
  KeySpec s{"gravity_m_per_s2",
            KeyType::kNumber,
            "m/s²",
            KeyRange::kNonNegative,
            false,
            ArmSection{}.gravity_m_per_s2,
            "Gravity along -z of the base frame (0: a horizontal arm or none)."};
  return s;
}();
inline const KeySpec kOrientation = [] {
  KeySpec s{
      "orientation",
      KeyType::kChoice,
      "",
      KeyRange::kFinite,
      false,
      0.0,
      "free: the tool's orientation is not controlled; hold: a rotational spring keeps the orientation at activation."};
  s.choices = {"free", "hold"};
  return s;
}();
inline const KeySpec kOrientationStiffness = [] {
  KeySpec s{"orientation_stiffness_Nm_per_rad",
            KeyType::kNumber,
            "N·m/rad",
            KeyRange::kNonNegative,
            false,
            ArmTorqueConfig{}.orientation_stiffness_Nm_per_rad,
            "K_o of orientation hold."};
  return s;
}();
inline const KeySpec kOrientationDamping = [] {
  KeySpec s{"orientation_damping_Nms_per_rad",
            KeyType::kNumber,
            "N·m·s/rad",
            KeyRange::kNonNegative,
            false,
            ArmTorqueConfig{}.orientation_damping_Nms_per_rad,
            "D_o of orientation hold."};
  return s;
}();
inline const KeySpec kPostureStiffness = [] {
  KeySpec s{"posture_stiffness_Nm_per_rad",
            KeyType::kNumber,
            "N·m/rad",
            KeyRange::kNonNegative,
            false,
            ArmTorqueConfig{}.posture_stiffness_Nm_per_rad,
            "Null-space posture spring to posture_q_rad (redundant arms; it never changes the tool force)."};
  return s;
}();
inline const KeySpec kPostureDamping = [] {
  KeySpec s{"posture_damping_Nms_per_rad",
            KeyType::kNumber,
            "N·m·s/rad",
            KeyRange::kNonNegative,
            false,
            ArmTorqueConfig{}.posture_damping_Nms_per_rad,
            "Null-space joint damping."};
  return s;
}();
inline const KeySpec kLimitMargin = [] {
  KeySpec s{"joint_limit_margin_rad",
            KeyType::kNumber,
            "rad",
            KeyRange::kNonNegative,
            false,
            ArmTorqueConfig{}.limit_margin,
            "The soft joint limit acts within this distance of each limit."};
  return s;
}();
inline const KeySpec kLimitStiffness = [] {
  KeySpec s{"joint_limit_stiffness_Nm_per_rad",
            KeyType::kNumber,
            "N·m/rad",
            KeyRange::kNonNegative,
            false,
            ArmTorqueConfig{}.limit_stiffness_Nm_per_rad,
            "Soft joint-limit spring (0: none)."};
  return s;
}();
inline const KeySpec kMinManipulability = [] {
  KeySpec s{"min_manipulability",
            KeyType::kNumber,
            "m³",
            KeyRange::kNonNegative,
            false,
            ArmDeviceConfig{}.min_manipulability,
            "A configuration whose translational manipulability is below this is singular: a fault."};
  return s;
}();
inline const KeySpec kCoriolis = [] {
  KeySpec s{"coriolis_compensation",        KeyType::kBool, "", KeyRange::kFinite, false, 0.0,
            "Add C(q, q̇)·q̇ to the torques."};
  return s;
}();
inline const KeySpec kFrictionViscous = [] {
  KeySpec s{"friction_viscous_Nms_per_rad",
            KeyType::kNumber,
            "N·m·s/rad",
            KeyRange::kNonNegative,
            false,
            ArmTorqueConfig{}.friction_viscous_Nms_per_rad,
            "Compensated viscous joint friction."};
  return s;
}();
inline const KeySpec kFrictionCoulomb = [] {
  KeySpec s{"friction_coulomb_Nm",
            KeyType::kNumber,
            "N·m",
            KeyRange::kNonNegative,
            false,
            ArmTorqueConfig{}.friction_coulomb_Nm,
            "Compensated Coulomb joint friction."};
  return s;
}();
inline const KeySpec kActuators = [] {
  KeySpec s{"actuators",
            KeyType::kChoice,
            "",
            KeyRange::kFinite,
            true,
            0.0,
            "The joint actuators: simulated (the simulated arm of the same URDF), mit (MIT-mode CAN motors, the mit "
            "section) or cia402 (CiA 402 drives in cyclic synchronous torque mode, the cia402 section)."};
  s.choices = {"simulated", "mit", "cia402"};
  return s;
}();
inline const KeySpec kSimViscous = [] {
  KeySpec s{"simulation.viscous_Nms_per_rad",
            KeyType::kNumber,
            "N·m·s/rad",
            KeyRange::kNonNegative,
            false,
            SimulatedArmConfig{}.viscous_Nms_per_rad,
            "Joint viscous friction of the simulated arm."};
  return s;
}();
inline const KeySpec kSimCoulomb = [] {
  KeySpec s{"simulation.coulomb_Nm",
            KeyType::kNumber,
            "N·m",
            KeyRange::kNonNegative,
            false,
            SimulatedArmConfig{}.coulomb_Nm,
            "Joint Coulomb friction (smoothed over 0.01 rad/s)."};
  return s;
}();
inline const KeySpec kSimEncoder = [] {
  KeySpec s{"simulation.encoder_resolution_rad",
            KeyType::kNumber,
            "rad",
            KeyRange::kNonNegative,
            false,
            SimulatedArmConfig{}.encoder_resolution_rad,
            "Joint positions are rounded to this step; 0 = exact."};
  return s;
}();
inline const KeySpec kSimSubsteps = [] {
  KeySpec s{"simulation.substeps",
            KeyType::kInteger,
            "",
            KeyRange::kInRange,
            false,
            static_cast<double>(SimulatedArmConfig{}.substeps),
            "Semi-implicit Euler steps per period."};
  s.low = 1;
  s.high = 100;
  return s;
}();
inline const KeySpec kSimStopStiffness = [] {
  KeySpec s{"simulation.stop_stiffness_Nm_per_rad",
            KeyType::kNumber,
            "N·m/rad",
            KeyRange::kNonNegative,
            false,
            SimulatedArmConfig{}.stop_stiffness_Nm_per_rad,
            "Stiffness of the joint stops beyond each limit."};
  return s;
}();
inline const KeySpec kSimStopDamping = [] {
  KeySpec s{"simulation.stop_damping_Nms_per_rad",
            KeyType::kNumber,
            "N·m·s/rad",
            KeyRange::kNonNegative,
            false,
            SimulatedArmConfig{}.stop_damping_Nms_per_rad,
            "Damping of the joint stops."};
  return s;
}();
inline const KeySpec kSimHandMass = [] {
  KeySpec s{"simulation.hand_mass_kg",
            KeyType::kNumber,
            "kg",
            KeyRange::kNonNegative,
            false,
            SimulatedArmConfig{}.hand_mass_kg,
            "The operator's hand at the tool (master): mass."};
  return s;
}();
inline const KeySpec kSimHandDamping = [] {
  KeySpec s{"simulation.hand_damping_Ns_per_m",         KeyType::kNumber,     "N·s/m", KeyRange::kNonNegative, false,
            SimulatedArmConfig{}.hand_damping_Ns_per_m, "The hand's damping."};
  return s;
}();
inline const KeySpec kSimHandStiffness = [] {
  KeySpec s{"simulation.hand_stiffness_N_per_m",
            KeyType::kNumber,
            "N/m",
            KeyRange::kNonNegative,
            false,
            SimulatedArmConfig{}.hand_stiffness_N_per_m,
            "The hand's stiffness to the tool's start position."};
  return s;
}();
inline const KeySpec kSimHandPush = [] {
  KeySpec s{"simulation.hand_push_N",
            KeyType::kDofValue,
            "N",
            KeyRange::kFinite,
            false,
            0.0,
            "The hand's scripted push (x, y, z, base frame) from hand_push_start_s on."};
  return s;
}();
inline const KeySpec kSimHandPushStart = [] {
  KeySpec s{"simulation.hand_push_start_s",         KeyType::kNumber,       "s", KeyRange::kNonNegative, false,
            SimulatedArmConfig{}.hand_push_start_s, "When the push starts."};
  return s;
}();
inline const KeySpec kSimEnvNormal = [] {
  KeySpec s{"simulation.environment_normal",
            KeyType::kDofValue,
            "",
            KeyRange::kFinite,
            false,
            0.0,
            "The environment plane's normal (x, y, z, into the obstacle; normalised); 0: no environment."};
  return s;
}();
inline const KeySpec kSimEnvOffset = [] {
  KeySpec s{"simulation.environment_offset_m",
            KeyType::kNumber,
            "m",
            KeyRange::kFinite,
            false,
            SimulatedArmConfig{}.environment_offset_m,
            "The plane: points p with normal·p > offset are inside the obstacle."};
  return s;
}();
inline const KeySpec kSimEnvStiffness = [] {
  KeySpec s{"simulation.environment_stiffness_N_per_m",
            KeyType::kNumber,
            "N/m",
            KeyRange::kNonNegative,
            false,
            SimulatedArmConfig{}.environment_stiffness_N_per_m,
            "Contact stiffness of the environment."};
  return s;
}();
inline const KeySpec kSimEnvDamping = [] {
  KeySpec s{"simulation.environment_damping_Ns_per_m",
            KeyType::kNumber,
            "N·s/m",
            KeyRange::kNonNegative,
            false,
            SimulatedArmConfig{}.environment_damping_Ns_per_m,
            "Contact damping (the contact only pushes)."};
  return s;
}();
inline const KeySpec kSweepSamples = [] {
  KeySpec s{"fixture_sweep.samples",
            KeyType::kInteger,
            "",
            KeyRange::kInRange,
            false,
            static_cast<double>(FixtureSweepConfig{}.samples),
            "Joint configurations the start-up check draws within the joint limits to find where the fixture plane "
            "can be reached; 0: the check uses the start configuration only."};
  s.low = 0;
  s.high = 100000;
  return s;
}();
inline const KeySpec kSweepDistance = [] {
  KeySpec s{"fixture_sweep.plane_distance_m",
            KeyType::kNumber,
            "m",
            KeyRange::kPositive,
            false,
            FixtureSweepConfig{}.plane_distance_m,
            "A drawn configuration is analysed when its tool point is within this distance of a fixture plane."};
  return s;
}();
inline const KeySpec kSweepSeed = [] {
  KeySpec s{"fixture_sweep.seed",
            KeyType::kInteger,
            "",
            KeyRange::kInRange,
            false,
            static_cast<double>(FixtureSweepConfig{}.seed),
            "Seed of the draw (SplitMix64: the same configurations on every machine)."};
  s.low = 0;
  s.high = 999999;
  return s;
}();
inline const KeySpec kSweepBucket = [] {
  KeySpec s{"fixture_sweep.bucket",
            KeyType::kNumber,
            "",
            KeyRange::kInRange,
            false,
            FixtureSweepConfig{}.bucket,
            "Relative width of the apparent mass and damping buckets: one analysis per bucket, at its configuration "
            "with the least damping; 0: one per configuration."};
  s.low = 0;
  s.high = 1;
  return s;
}();

// The `mit` section's keys with a value (the can bus section and the joints list are read apart): each default is
// MitJointBusConfig's.
inline const MitJointBusConfig kMit{};
inline const KeySpec kMitSection{.key = "mit",
                                 .type = KeyType::kSection,
                                 .meaning = "MIT-mode CAN motors (actuators: mit): the mit.* keys (`device.arm.mit`)."};
/// `mit.bus`: 0 the simulated MIT arm in this process, 1 the `can` section's bus.
inline const KeySpec kMitBus{.key = "mit.bus",
                             .type = KeyType::kChoice,
                             .required = true,
                             .meaning =
                                 "simulated (the simulated arm of `simulation` on simulated DM-J motors, in this "
                                 "process) or can (the `can` section's bus).",
                             .choices = {"simulated", "can"}};
inline const KeySpec kMitFd{.key = "mit.fd",
                            .type = KeyType::kBool,
                            .meaning = "CAN FD frames with the bit-rate switch.",
                            .default_bool = kMit.fd};
inline const KeySpec kMitNominalBitrate{.key = "mit.nominal_bitrate_bit_per_s",
                                        .unit = "bit/s",
                                        .range = KeyRange::kPositive,
                                        .default_value = kMit.nominal_bitrate_bit_per_s,
                                        .meaning = "The bus-load budget's arbitration bit rate."};
inline const KeySpec kMitDataBitrate{.key = "mit.data_bitrate_bit_per_s",
                                     .unit = "bit/s",
                                     .range = KeyRange::kPositive,
                                     .default_value = kMit.data_bitrate_bit_per_s,
                                     .meaning = "The bus-load budget's FD data bit rate."};
inline const KeySpec kMitMaxBusLoad{.key = "mit.max_bus_load",
                                    .range = KeyRange::kInRange,
                                    .default_value = kMit.max_bus_load,
                                    .meaning = "The budget: a rig above this fraction of the bus is refused.",
                                    .low = 0.01,
                                    .high = 1.0};
inline const KeySpec kMitRate{.key = "mit.rate_hz",
                              .unit = "Hz",
                              .range = KeyRange::kInRange,
                              .default_value = kMit.rate_hz,
                              .meaning = "The cycle rate the budget is computed at: set it to the process's rate_hz.",
                              .low = 1.0,
                              .high = 100000.0};
/// `mit.control`: the word's index is MitControl.
inline const KeySpec kMitControl{
    .key = "mit.control",
    .type = KeyType::kChoice,
    .meaning =
        "torque (Kp = Kd = 0, the arm's torque as each motor's feed-forward) or pd (the motor's own PD with "
        "each joint's kp_Nm_per_rad, kd_Nms_per_rad, plus the torque).",
    .choices = {"torque", "pd"},
    .default_choice = static_cast<int>(kMit.control)};
inline const KeySpec kMitMissingLimit{.key = "mit.missing_limit",
                                      .type = KeyType::kInteger,
                                      .range = KeyRange::kInRange,
                                      .default_value = static_cast<double>(kMit.missing_limit),
                                      .meaning = "Exchanges in a row without a reply that fault the joint.",
                                      .low = 1,
                                      .high = 1000};
inline const KeySpec kMitAnswerTimeout{.key = "mit.answer_timeout_ms",
                                       .unit = "ms",
                                       .range = KeyRange::kInRange,
                                       .default_value = kMit.answer_timeout_ms,
                                       .meaning = "Set-up: how long a register read, enable or disable waits.",
                                       .low = 1.0,
                                       .high = 10000.0};
inline const KeySpec kMitMotorTimeout{
    .key = "mit.motor_timeout_ms",
    .unit = "ms",
    .range = KeyRange::kInRange,
    .default_value = kMit.motor_timeout_ms,
    .meaning =
        "Each motor's own CAN timeout (register 9), written at configure: a dead host leaves the motor "
        "disabled; 0 = off.",
    .low = 0.0,
    .high = 3000.0};
inline const KeySpec kMitReplyWait{.key = "mit.reply_wait_us",
                                   .unit = "µs",
                                   .range = KeyRange::kInRange,
                                   .default_value = kMit.reply_wait_us,
                                   .meaning = "bus: can: how long each exchange waits for its replies.",
                                   .low = 0.0,
                                   .high = 10000.0};
inline const KeySpec kMitTemperatureWarning{
    .key = "mit.temperature_warning_C",
    .unit = "°C",
    .default_value = kMit.temperature_warning_C,
    .meaning = "MOS or rotor temperature at or above which the arm reports kArmWarningTemperature."};
inline const KeySpec kMitTemperatureFault{.key = "mit.temperature_fault_C",
                                          .unit = "°C",
                                          .default_value = kMit.temperature_fault_C,
                                          .meaning = "MOS or rotor temperature at or above which the joint faults."};
inline const KeySpec kMitModelsFile{
    .key = "mit.models_file",
    .type = KeyType::kText,
    .meaning = "The motor models table (beside this config); empty: the shipped deploy/motors/mit-models.yaml."};

// The `cia402` section's keys with a value (the buses list and the joints list are read apart): each default is
// Cia402JointBusConfig's.
inline const Cia402JointBusConfig kCia402{};
inline const KeySpec kCia402Section{
    .key = "cia402",
    .type = KeyType::kSection,
    .meaning =
        "CiA 402 drives in cyclic synchronous torque mode (actuators: cia402): the cia402.* keys "
        "(`device.arm.cia402`)."};
/// `cia402.bus`: 0 the simulated arm on simulated drives in this process, 1 the `buses`.
inline const KeySpec kCia402Bus{.key = "cia402.bus",
                                .type = KeyType::kChoice,
                                .required = true,
                                .meaning =
                                    "simulated (the simulated arm on simulated CiA 402 drives, in this process) "
                                    "or can (the `buses`).",
                                .choices = {"simulated", "can"}};
inline const KeySpec kCia402NominalBitrate{.key = "cia402.nominal_bitrate_bit_per_s",
                                           .unit = "bit/s",
                                           .range = KeyRange::kPositive,
                                           .default_value = kCia402.nominal_bitrate_bit_per_s,
                                           .meaning = "The bus-load budget's (and the emulated buses') bit rate."};
inline const KeySpec kCia402MaxBusLoad{.key = "cia402.max_bus_load",
                                       .range = KeyRange::kInRange,
                                       .default_value = kCia402.max_bus_load,
                                       .meaning = "The budget: a bus above this fraction is refused.",
                                       .low = 0.01,
                                       .high = 1.0};
inline const KeySpec kCia402Rate{.key = "cia402.rate_hz",
                                 .unit = "Hz",
                                 .range = KeyRange::kInRange,
                                 .default_value = kCia402.rate_hz,
                                 .meaning =
                                     "The cycle rate: the SYNC period and the budget's rate; the process's "
                                     "rate_hz.",
                                 .low = 1.0,
                                 .high = 100000.0};
inline const KeySpec kCia402Stale{.key = "cia402.stale_after_ms",
                                  .unit = "ms",
                                  .range = KeyRange::kInRange,
                                  .default_value = kCia402.stale_after_ms,
                                  .meaning = "No TPDO for this long faults the joint.",
                                  .low = 1.0,
                                  .high = 1000.0};
inline const KeySpec kCia402HeartbeatPeriod{.key = "cia402.drive_heartbeat_period_ms",
                                            .unit = "ms",
                                            .range = KeyRange::kInRange,
                                            .default_value = kCia402.drive_heartbeat_period_ms,
                                            .meaning = "Each drive's heartbeat, 0x1017.",
                                            .low = 1.0,
                                            .high = 10000.0};
inline const KeySpec kCia402HeartbeatTimeout{.key = "cia402.heartbeat_timeout_ms",
                                             .unit = "ms",
                                             .range = KeyRange::kInRange,
                                             .default_value = kCia402.heartbeat_timeout_ms,
                                             .meaning = "The host's consumer of each drive's heartbeat.",
                                             .low = 1.0,
                                             .high = 60000.0};
inline const KeySpec kCia402HostNodeId = [] {
  KeySpec s{"cia402.host_node_id",
            KeyType::kInteger,
            "",
            KeyRange::kInRange,
            false,
            static_cast<double>(kCia402.host_node_id),
            "The host's node-ID in its heartbeat on every bus (0x700 + it) and in each drive's consumer of it "
            "(0x1016:01); no drive may use it."};
  s.low = 1;
  s.high = 127;
  return s;
}();
inline const KeySpec kCia402HostHeartbeatPeriod{.key = "cia402.host_heartbeat_period_ms",
                                                .unit = "ms",
                                                .range = KeyRange::kInRange,
                                                .default_value = kCia402.host_heartbeat_period_ms,
                                                .meaning = "The host's heartbeat on every bus (node host_node_id).",
                                                .low = 1.0,
                                                .high = 10000.0};
inline const KeySpec kCia402DriveConsumerTimeout{
    .key = "cia402.drive_consumer_timeout_ms",
    .unit = "ms",
    .range = KeyRange::kInRange,
    .default_value = kCia402.drive_consumer_timeout_ms,
    .meaning =
        "Each drive's consumer of the host's heartbeat (0x1016:01, on while active): a dead host faults every "
        "drive this long after its last heartbeat; 0 = off, else above host_heartbeat_period_ms.",
    .low = 0.0,
    .high = 65535.0};
inline const KeySpec kCia402SdoTimeout{.key = "cia402.sdo_timeout_ms",
                                       .unit = "ms",
                                       .range = KeyRange::kInRange,
                                       .default_value = kCia402.sdo_timeout_ms,
                                       .meaning = "Set-up: how long one SDO waits.",
                                       .low = 1.0,
                                       .high = 10000.0};
inline const KeySpec kCia402ActivateTimeout{.key = "cia402.activate_timeout_ms",
                                            .unit = "ms",
                                            .range = KeyRange::kInRange,
                                            .default_value = kCia402.activate_timeout_ms,
                                            .meaning = "Set-up: each state machine step and the first TPDOs.",
                                            .low = 1.0,
                                            .high = 10000.0};

/// Every key of the table, built at its first use (after static initialisation).
inline const KeySpec kRuntimeEnabled = [] {
  KeySpec s{"runtime_limit.enabled",
            KeyType::kBool,
            "",
            KeyRange::kFinite,
            false,
            0.0,
            "The run-time limit: a thread of its own recomputes the fixture's stability limit at the arm's current "
            "configuration and lowers the fixture stiffness below it (docs/arms.md, \"Stability\")."};
  return s;
}();
inline const KeySpec kRuntimeRate = [] {
  KeySpec s{"runtime_limit.rate_hz",
            KeyType::kNumber,
            "Hz",
            KeyRange::kInRange,
            false,
            ConfigurationLimitOptions{}.rate_hz,
            "How often the limit at the current configuration is recomputed (one limit search each, about 20 ms)."};
  s.low = 0.1;
  s.high = 50.0;
  return s;
}();
inline const KeySpec kRuntimeMargin = [] {
  KeySpec s{"runtime_limit.margin",
            KeyType::kNumber,
            "",
            KeyRange::kInRange,
            false,
            ConfigurationLimitOptions{}.margin,
            "The fixture is lowered to (1 - margin) x the limit at the configuration when it is stiffer than that."};
  s.low = 0.0;
  s.high = 0.9;
  return s;
}();
inline const KeySpec kRuntimeHysteresis = [] {
  KeySpec s{"runtime_limit.hysteresis",
            KeyType::kNumber,
            "",
            KeyRange::kInRange,
            false,
            ConfigurationLimitOptions{}.hysteresis,
            "A lowered fixture is raised again to (1 - margin) x limit / (1 + hysteresis), at most the configured "
            "stiffness, once that is this fraction above its stiffness."};
  s.low = 0.0;
  s.high = 1.0;
  return s;
}();
inline const KeySpec kRuntimeForceRate = [] {
  KeySpec s{"runtime_limit.max_force_rate_N_per_s",
            KeyType::kNumber,
            "N/s",
            KeyRange::kPositive,
            false,
            ConfigurationLimitOptions{}.max_force_rate_N_per_s,
            "The stiffness ramps so that the fixture force at max_penetration_m changes at most this fast."};
  return s;
}();
inline const KeySpec kRuntimePenetration = [] {
  KeySpec s{"runtime_limit.max_penetration_m",
            KeyType::kNumber,
            "m",
            KeyRange::kPositive,
            false,
            ConfigurationLimitOptions{}.max_penetration_m,
            "The penetration the ramp's force rate is bounded at."};
  return s;
}();

inline const auto& All() {
  static const std::array table{kUrdf,
                                kBaseLink,
                                kToolLink,
                                kToolOffset,
                                kWorkspaceOrigin,
                                kGravity,
                                kOrientation,
                                kOrientationStiffness,
                                kOrientationDamping,
                                kPostureStiffness,
                                kPostureDamping,
                                kLimitMargin,
                                kLimitStiffness,
                                kMinManipulability,
                                kCoriolis,
                                kFrictionViscous,
                                kFrictionCoulomb,
                                kActuators,
                                kSimViscous,
                                kSimCoulomb,
                                kSimEncoder,
                                kSimSubsteps,
                                kSimStopStiffness,
                                kSimStopDamping,
                                kSimHandMass,
                                kSimHandDamping,
                                kSimHandStiffness,
                                kSimHandPush,
                                kSimHandPushStart,
                                kSimEnvNormal,
                                kSimEnvOffset,
                                kSimEnvStiffness,
                                kSimEnvDamping,
                                kSweepSamples,
                                kSweepDistance,
                                kSweepSeed,
                                kSweepBucket,
                                kMitSection,
                                kMitBus,
                                kMitFd,
                                kMitNominalBitrate,
                                kMitDataBitrate,
                                kMitMaxBusLoad,
                                kMitRate,
                                kMitControl,
                                kMitMissingLimit,
                                kMitAnswerTimeout,
                                kMitMotorTimeout,
                                kMitReplyWait,
                                kMitTemperatureWarning,
                                kMitTemperatureFault,
                                kMitModelsFile,
                                kCia402Section,
                                kCia402Bus,
                                kCia402NominalBitrate,
                                kCia402MaxBusLoad,
                                kCia402Rate,
                                kCia402Stale,
                                kCia402HeartbeatPeriod,
                                kCia402HeartbeatTimeout,
                                kCia402HostNodeId,
                                kCia402HostHeartbeatPeriod,
                                kCia402DriveConsumerTimeout,
                                kCia402SdoTimeout,
                                kCia402ActivateTimeout,
                                kRuntimeEnabled,
                                kRuntimeRate,
                                kRuntimeMargin,
                                kRuntimeHysteresis,
                                kRuntimeForceRate,
                                kRuntimePenetration};
  return table;
}

}  // namespace teleop::device::arm::arm_keys
