#pragma once

// The `device.loopback` keys with a value, each written once (teleop/config/key_table.hpp): the reader
// (loopback_backend.cpp), `--list-devices` and the rows of docs/configuration.md come from this table. A key that is
// not required takes its default from the config struct's member initialiser (teleop/device/loopback.hpp), the one
// place it is written: a config built in code and one read from YAML without the key get the same value.

#include <array>

#include "teleop/config/key_table.hpp"
#include "teleop/device/loopback.hpp"

namespace teleop::device::loopback_keys {

using config::KeyRange;
using config::KeySpec;
using config::KeyType;

inline const KeySpec kMass{"mass_kg",
                           KeyType::kNumber,
                           "kg",
                           KeyRange::kPositive,
                           true,
                           0.0,
                           "Device mass per DOF. Paper §4.1: master 0.040, slave 0.036."};
inline const KeySpec kDamping{"damping_Ns_per_m",
                              KeyType::kNumber,
                              "N·s/m",
                              KeyRange::kNonNegative,
                              true,
                              0.0,
                              "Device damping. Paper: master 0.41, slave 0.49."};
inline const KeySpec kEncoderResolution{"encoder_resolution_m",
                                        KeyType::kNumber,
                                        "m",
                                        KeyRange::kNonNegative,
                                        false,
                                        LoopbackPlantConfig{}.encoder_resolution_m,
                                        "Position reads are rounded to this step; 0 = exact."};
inline const KeySpec kInitialPosition{
    "initial_position_m", KeyType::kDofValue, "m", KeyRange::kFinite, false, 0.0,  // empty = 0
    "Start position."};
inline constexpr SimulatedOperatorConfig kOperator{};  // the operator's defaults
inline const KeySpec kOperatorSection{
    .key = "operator",
    .type = KeyType::kSection,
    .meaning =
        "The simulated hand (usually the master): the operator.* keys (`device.loopback.operator`); absent: no "
        "operator."};
inline const KeySpec kOperatorMass{"operator.mass_kg",
                                   KeyType::kNumber,
                                   "kg",
                                   KeyRange::kNonNegative,
                                   false,
                                   kOperator.mass_kg,
                                   "m_h, added to the device mass."};
inline const KeySpec kOperatorDamping{"operator.damping_Ns_per_m",
                                      KeyType::kNumber,
                                      "N·s/m",
                                      KeyRange::kNonNegative,
                                      false,
                                      kOperator.damping_Ns_per_m,
                                      "b_h."};
inline const KeySpec kOperatorStiffness{"operator.stiffness_N_per_m",
                                        KeyType::kNumber,
                                        "N/m",
                                        KeyRange::kNonNegative,
                                        false,
                                        kOperator.stiffness_N_per_m,
                                        "k_h."};

// The keys of one segment of `operator.script` (a list; each item's keys depend on its `type`, KeySpec::when).
inline constexpr OperatorSegment kSegment{};  // a segment's defaults
inline const KeySpec kSegmentType{
    .key = "operator.script[].type",
    .type = KeyType::kChoice,
    .required = true,
    .meaning =
        "hold keeps the level the earlier segments on the same axis had just before start_s; step, ramp and sine "
        "drive their own; each type takes only its own keys.",
    .choices = {"hold", "step", "ramp", "sine"}};
inline const KeySpec kSegmentAxis{.key = "operator.script[].axis",
                                  .type = KeyType::kInteger,
                                  .range = KeyRange::kInRange,
                                  .default_value = static_cast<double>(kSegment.axis),
                                  .meaning = "The DOF it drives, below dof.",
                                  .low = 0,
                                  .high = kMaxDof - 1};
inline const KeySpec kSegmentStart{.key = "operator.script[].start_s",
                                   .unit = "s",
                                   .range = KeyRange::kNonNegative,
                                   .required = true,
                                   .meaning = "Start time (simulated time since the start)."};
inline const KeySpec kRampDuration{.key = "operator.script[].duration_s",
                                   .unit = "s",
                                   .range = KeyRange::kPositive,
                                   .required = true,
                                   .meaning = "Ramp length (a ramp needs time; follow it with a hold).",
                                   .when = "ramp"};
/// duration_s of the types that may last until the end of the run.
constexpr KeySpec OpenDuration(const char* type) {
  return {.key = "operator.script[].duration_s",
          .unit = "s",
          .range = KeyRange::kNonNegative,
          .default_value = kSegment.duration_s,
          .meaning = "Length; 0 = until the end of the run.",
          .when = type};
}
inline const KeySpec kHoldDuration = OpenDuration("hold");
inline const KeySpec kStepDuration = OpenDuration("step");
inline const KeySpec kSineDuration = OpenDuration("sine");
inline const KeySpec kRampFrom{.key = "operator.script[].from_N",
                               .unit = "N",
                               .required = true,
                               .meaning = "Level at start_s: linear from from_N to to_N.",
                               .when = "ramp"};
inline const KeySpec kRampTo{.key = "operator.script[].to_N",
                             .unit = "N",
                             .required = true,
                             .meaning = "Level at start_s + duration_s.",
                             .when = "ramp"};
inline const KeySpec kStepTo{
    .key = "operator.script[].to_N", .unit = "N", .required = true, .meaning = "Constant level.", .when = "step"};
inline const KeySpec kSineAmplitude{.key = "operator.script[].amplitude_N",
                                    .unit = "N",
                                    .required = true,
                                    .meaning = "offset_N + amplitude_N·sin(2π frequency_hz (t − start_s)).",
                                    .when = "sine"};
inline const KeySpec kSineFrequency{.key = "operator.script[].frequency_hz",
                                    .unit = "Hz",
                                    .range = KeyRange::kPositive,
                                    .required = true,
                                    .meaning = "Sine frequency.",
                                    .when = "sine"};
inline const KeySpec kSineOffset{.key = "operator.script[].offset_N",
                                 .unit = "N",
                                 .default_value = kSegment.offset_N,
                                 .meaning = "Sine offset.",
                                 .when = "sine"};

inline const SimulatedEnvironmentConfig kEnvironment{};  // the environment's defaults
inline const KeySpec kEnvironmentSection{
    .key = "environment",
    .type = KeyType::kSection,
    .meaning =
        "The simulated environment (slave): the environment.* keys (`device.loopback.environment`); absent: free "
        "space."};
/// `environment.type`: the word's index is SimulatedEnvironmentConfig::Kind.
inline const KeySpec kEnvironmentType{.key = "environment.type",
                                      .type = KeyType::kChoice,
                                      .required = true,
                                      .meaning = "Free space (no other key), or a spring–damper wall that only pushes.",
                                      .choices = {"free", "wall"}};
inline const KeySpec kWallAxis{.key = "environment.axis",
                               .type = KeyType::kInteger,
                               .range = KeyRange::kInRange,
                               .default_value = static_cast<double>(kEnvironment.axis),
                               .meaning = "The wall's DOF, below dof.",
                               .low = 0,
                               .high = kMaxDof - 1,
                               .when = "wall"};
inline const KeySpec kWallPosition{.key = "environment.position_m",
                                   .unit = "m",
                                   .required = true,
                                   .meaning = "The wall occupies x_axis > position_m.",
                                   .when = "wall"};
inline const KeySpec kWallStiffness{.key = "environment.stiffness_N_per_m",
                                    .unit = "N/m",
                                    .range = KeyRange::kPositive,
                                    .required = true,
                                    .meaning = "Wall stiffness.",
                                    .when = "wall"};
inline const KeySpec kWallDamping{.key = "environment.damping_Ns_per_m",
                                  .unit = "N·s/m",
                                  .range = KeyRange::kNonNegative,
                                  .default_value = kEnvironment.damping_Ns_per_m,
                                  .meaning = "Wall damping (only while in contact).",
                                  .when = "wall"};

/// Every key of the table, built at its first use (after static initialisation: its elements are dynamically
/// initialised constants, and a copy made during static initialisation could read one not yet initialised).
inline const auto& All() {
  static const std::array table{kMass,
                                kDamping,
                                kEncoderResolution,
                                kInitialPosition,
                                kOperatorSection,
                                kOperatorMass,
                                kOperatorDamping,
                                kOperatorStiffness,
                                kSegmentType,
                                kSegmentAxis,
                                kSegmentStart,
                                kRampDuration,
                                kHoldDuration,
                                kStepDuration,
                                kSineDuration,
                                kRampFrom,
                                kRampTo,
                                kStepTo,
                                kSineAmplitude,
                                kSineFrequency,
                                kSineOffset,
                                kEnvironmentSection,
                                kEnvironmentType,
                                kWallAxis,
                                kWallPosition,
                                kWallStiffness,
                                kWallDamping};
  return table;
}

}  // namespace teleop::device::loopback_keys
