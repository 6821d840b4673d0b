#pragma once

// The `device.loopback` keys with a value, each written once (teleop/config/key_table.hpp): the reader
// (loopback_backend.cpp), `--list-devices` and the rows of docs/configuration.md come from this table.

#include <array>

#include "teleop/config/key_table.hpp"

namespace teleop::device::loopback_keys {

using config::KeyRange;
using config::KeySpec;
using config::KeyType;

inline constexpr KeySpec kMass{"mass_kg",
                               KeyType::kNumber,
                               "kg",
                               KeyRange::kPositive,
                               true,
                               0.0,
                               "Device mass per DOF. Paper §4.1: master 0.040, slave 0.036."};
inline constexpr KeySpec kDamping{"damping_Ns_per_m",
                                  KeyType::kNumber,
                                  "N·s/m",
                                  KeyRange::kNonNegative,
                                  true,
                                  0.0,
                                  "Device damping. Paper: master 0.41, slave 0.49."};
inline constexpr KeySpec kEncoderResolution{"encoder_resolution_m",
                                            KeyType::kNumber,
                                            "m",
                                            KeyRange::kNonNegative,
                                            false,
                                            0.0,
                                            "Position reads are rounded to this step; 0 = exact."};
inline constexpr KeySpec kInitialPosition{"initial_position_m", KeyType::kDofValue, "m", KeyRange::kFinite, false, 0.0,
                                          "Start position."};
inline constexpr KeySpec kOperatorMass{
    "operator.mass_kg", KeyType::kNumber, "kg", KeyRange::kNonNegative, false, 0.0, "m_h, added to the device mass."};
inline constexpr KeySpec kOperatorDamping{
    "operator.damping_Ns_per_m", KeyType::kNumber, "N·s/m", KeyRange::kNonNegative, false, 0.0, "b_h."};
inline constexpr KeySpec kOperatorStiffness{
    "operator.stiffness_N_per_m", KeyType::kNumber, "N/m", KeyRange::kNonNegative, false, 0.0, "k_h."};

inline constexpr std::array kAll{kMass,         kDamping,         kEncoderResolution, kInitialPosition,
                                 kOperatorMass, kOperatorDamping, kOperatorStiffness};

}  // namespace teleop::device::loopback_keys
