#pragma once

// The `device.admittance` keys with a value, each written once (teleop/config/key_table.hpp): the reader
// (admittance_backend.cpp), `--list-devices` and the rows of docs/configuration.md come from this table; an optional
// key's default is AdmittanceConfig's member initialiser (admittance_device.hpp), read from a default-constructed
// struct, so a config built in code and one read from YAML without the key agree.

#include <array>

#include "admittance_device.hpp"
#include "teleop/config/key_table.hpp"

namespace teleop::device::admittance_keys {

using config::KeyRange;
using config::KeySpec;
using config::KeyType;

inline const AdmittanceConfig kDefaults{};

/// `mode`: the modes its words name, in the order of kMode's choices.
inline constexpr std::array kModes{fieldbus::Cia402Mode::kCyclicSynchronousPosition,
                                   fieldbus::Cia402Mode::kCyclicSynchronousVelocity,
                                   fieldbus::Cia402Mode::kCyclicSynchronousTorque};
inline const KeySpec kMode{.key = "mode",
                           .type = KeyType::kChoice,
                           .meaning =
                               "The target the drives take: position (CiA 402 mode 8) or velocity (9) of the virtual "
                               "mass; torque (10): the law's force through the transmission, no virtual mass (m_v, "
                               "b_v are then the axis's own mass and damping at the tool).",
                           .choices = {"position", "velocity", "torque"},
                           .default_choice = kDefaults.mode == kModes[2]   ? 2
                                             : kDefaults.mode == kModes[1] ? 1
                                                                           : 0};

inline const KeySpec kVirtualMass{.key = "virtual_mass_kg",
                                  .type = KeyType::kDofValue,
                                  .unit = "kg",
                                  .range = KeyRange::kPositive,
                                  .required = true,
                                  .meaning = "m_v per axis: one number or one per DOF."};
inline const KeySpec kVirtualDamping{.key = "virtual_damping_Ns_per_m",
                                     .type = KeyType::kDofValue,
                                     .unit = "N·s/m",
                                     .range = KeyRange::kNonNegative,
                                     .required = true,
                                     .meaning = "b_v per axis: one number or one per DOF."};
inline const KeySpec kMaxForce{.key = "max_force_N",
                               .unit = "N",
                               .range = KeyRange::kPositive,
                               .default_value = kDefaults.max_force_N,
                               .meaning = "The law's force is clamped to it."};
inline const KeySpec kMaxVelocity{.key = "max_velocity_m_per_s",
                                  .unit = "m/s",
                                  .range = KeyRange::kPositive,
                                  .default_value = kDefaults.max_velocity_m_per_s,
                                  .meaning = "The virtual mass's speed limit."};
inline const KeySpec kPositionLoopBandwidth{
    .key = "position_loop_bandwidth_rad_per_s",
    .unit = "rad/s",
    .range = KeyRange::kPositive,
    .default_value = kDefaults.position_loop_bandwidth_rad_per_s,
    .meaning =
        "The drives' position-loop bandwidth, from their tuning; 0 (unset): the stability check is not "
        "applicable."};
inline const KeySpec kBandwidthRatio{.key = "bandwidth_ratio",
                                     .range = KeyRange::kInRange,
                                     .default_value = kDefaults.bandwidth_ratio,
                                     .meaning = "How much faster than b_v/m_v and than sqrt(K/m_v) the loop must be.",
                                     .low = 1.0,
                                     .high = 1000.0};
inline const KeySpec kMaxStiffness{
    .key = "max_stiffness_N_per_m",
    .unit = "N/m",
    .range = KeyRange::kNonNegative,
    .default_value = kDefaults.max_stiffness_N_per_m,
    .meaning =
        "K: the stiffest spring the virtual mass meets, the coupling's `law.kp_N_per_m` plus the fixture's "
        "stiffness; 0: only b_v/m_v is checked."};
inline const KeySpec kCyclePeriod{.key = "cycle_period_ms",
                                  .unit = "ms",
                                  .range = KeyRange::kPositive,
                                  .default_value = kDefaults.cycle_period_s * 1e3,
                                  .meaning = "The drives' cycle, written to 0x1006."};
inline const KeySpec kMaxTrackingError{
    .key = "max_tracking_error_m",
    .unit = "m",
    .range = KeyRange::kPositive,
    .default_value = kDefaults.max_tracking_error_m,
    .meaning =
        "The largest distance between the drive's measured position and the virtual position two cycles "
        "earlier; 0 (unset): 2 · (v_max/ω + v_max · T) with ω = `position_loop_bandwidth_rad_per_s` (unset: the "
        "slowest loop `bandwidth_ratio` admits), v_max = `max_velocity_m_per_s`, T the cycle; at least 1 mm."};
inline const KeySpec kTrackingErrorCycles{
    .key = "tracking_error_cycles",
    .type = KeyType::kInteger,
    .range = KeyRange::kInRange,
    .default_value = static_cast<double>(kDefaults.tracking_error_cycles),
    .meaning =
        "Consecutive cycles beyond `max_tracking_error_m` that set a driver fault (the pair goes to the safe "
        "state, the virtual mass held where the joint is).",
    .low = 1,
    .high = 100000};

/// The keys of each `drives` entry; defaults from AdmittanceAxisConfig (and its fieldbus::Cia402DriveConfig).
inline const AdmittanceAxisConfig kAxis{};
inline const KeySpec kDriveNodeId{.key = "drives[].node_id",
                                  .type = KeyType::kInteger,
                                  .range = KeyRange::kInRange,
                                  .required = true,
                                  .meaning = "CANopen node-ID, distinct across the drives.",
                                  .low = 1,
                                  .high = 127};
inline const KeySpec kDriveTransmission{.key = "drives[].transmission_m_per_rad",
                                        .unit = "m/rad",
                                        .range = KeyRange::kPositive,
                                        .default_value = kAxis.transmission_m_per_rad,
                                        .meaning = "Axis metres per joint radian (a capstan radius, a lead / 2π)."};
inline const KeySpec kDriveRatedTorque{.key = "drives[].rated_torque_Nm",
                                       .unit = "N·m",
                                       .range = KeyRange::kPositive,
                                       .default_value = kAxis.drive.scaling.rated_torque_Nm,
                                       .meaning = "0x6076; checked where the drive has it."};
inline const KeySpec kDrivePositionUnit{.key = "drives[].position_rad_per_count",
                                        .unit = "rad",
                                        .range = KeyRange::kPositive,
                                        .default_value = kAxis.drive.scaling.position_rad_per_count,
                                        .meaning = "Joint rad per position unit (0x6064, 0x607A)."};
inline const KeySpec kDriveVelocityUnit{.key = "drives[].velocity_rad_per_s_per_unit",
                                        .unit = "rad/s",
                                        .range = KeyRange::kPositive,
                                        .default_value = kAxis.drive.scaling.velocity_rad_per_s_per_unit,
                                        .meaning = "Joint rad/s per velocity unit (0x606C, 0x60FF)."};
inline const KeySpec kDriveMaxTorque{.key = "drives[].max_torque_Nm",
                                     .unit = "N·m",
                                     .range = KeyRange::kPositive,
                                     .default_value = kAxis.drive.max_torque_Nm,
                                     .meaning = "0x6072, the drive loops' torque limit."};
inline const KeySpec kDriveHeartbeatPeriod{.key = "drives[].heartbeat_period_ms",
                                           .unit = "ms",
                                           .range = KeyRange::kPositive,
                                           .default_value = kAxis.drive.drive_heartbeat_period_ms,
                                           .meaning = "The drive's heartbeat, 0x1017."};
inline const KeySpec kDriveHeartbeatTimeout{.key = "drives[].heartbeat_timeout_ms",
                                            .unit = "ms",
                                            .range = KeyRange::kPositive,
                                            .default_value = kAxis.drive.heartbeat_timeout_ms,
                                            .meaning = "The host's consumer timeout, more than the period."};
inline const KeySpec kDriveStaleAfter{.key = "drives[].stale_after_ms",
                                      .unit = "ms",
                                      .range = KeyRange::kPositive,
                                      .default_value = kAxis.drive.stale_after_ms,
                                      .meaning = "TPDO data older than this is a fault."};

inline const KeySpec kDriveEds{
    .key = "drives[].eds",
    .type = KeyType::kText,
    .meaning =
        "The drive's EDS/DCF file (a relative path is beside the config file), checked at configure "
        "(docs/cia402.md, \"EDS / DCF\"); "
        "\"\" = none.",
    .default_text = kAxis.drive.eds_file.c_str()};

inline const KeySpec kDriveDirection{
    .key = "drives[].direction",
    .type = KeyType::kInteger,
    .range = KeyRange::kInRange,
    .default_value = kAxis.drive.scaling.sign,
    .meaning = "1 or -1 (0 is refused): the drive's positive direction against the axis'.",
    .low = -1,
    .high = 1};

/// Every key of the table, built at its first use (after static initialisation: its elements are dynamically
/// initialised constants, and a copy made during static initialisation could read one not yet initialised).
inline const auto& All() {
  static const std::array table{kMode,
                                kVirtualMass,
                                kVirtualDamping,
                                kMaxForce,
                                kMaxVelocity,
                                kPositionLoopBandwidth,
                                kBandwidthRatio,
                                kMaxStiffness,
                                kCyclePeriod,
                                kMaxTrackingError,
                                kTrackingErrorCycles,
                                kDriveNodeId,
                                kDriveTransmission,
                                kDriveRatedTorque,
                                kDrivePositionUnit,
                                kDriveVelocityUnit,
                                kDriveMaxTorque,
                                kDriveHeartbeatPeriod,
                                kDriveHeartbeatTimeout,
                                kDriveStaleAfter,
                                kDriveEds,
                                kDriveDirection};
  return table;
}

}  // namespace teleop::device::admittance_keys
