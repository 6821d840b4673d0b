#pragma once

// The `device.hybrid` keys with a number or a word, each written once (teleop/config/key_table.hpp): the reader
// (hybrid_backend.cpp), `--list-devices` and the rows of docs/configuration.md come from this table; each default is
// the member initialiser of the rig's config structs (hybrid_rig.hpp, motor_model.hpp, particle_brake.hpp,
// rig_sensing.hpp), read from a default-constructed HybridRigConfig.

#include <array>

#include "device/hybrid/hybrid_device.hpp"
#include "device/hybrid/hybrid_rig.hpp"
#include "teleop/config/key_table.hpp"

namespace teleop::device::hybrid::keys {

using config::KeyRange;
using config::KeySpec;
using config::KeyType;

inline const HybridRigConfig kRig{};

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

/// Every key of the table, built at its first use (after static initialisation: its elements are dynamically
/// initialised constants, and a copy made during static initialisation could read one not yet initialised).
inline const auto& All() {
  static const std::array table{kRigKind,
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
                                kAllocationBrakeMismatch};
  return table;
}

}  // namespace teleop::device::hybrid::keys
