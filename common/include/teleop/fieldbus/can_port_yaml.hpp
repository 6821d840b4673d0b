#pragma once

// The YAML reader of a driver's CAN bus section (`device.admittance.can`, `device.cobot.fieldbus.can`,
// `device.hybrid.fieldbus.can`; docs/configuration.md), written once for every backend that has one. Errors go
// through config::Field::Fail ("FILE:LINE:COL: key 'a.b': reason").

#include <array>

#include "teleop/fieldbus/can_port_config.hpp"

namespace teleop::config {
class Field;
}  // namespace teleop::config

namespace teleop::fieldbus {

/// Whether `medium` may be left out (then CanPortConfig's default, socketcan) or must be written.
enum class CanMediumKey : bool { kOptional, kRequired };

/// Reads `medium` (socketcan | emulated), `interface` (socketcan only; required there, 1..15 characters), `bus`
/// ("HOST:PORT" of the teleop-canbus daemon, emulated only) and `connect_timeout_ms` (> 0) into `can`; an unknown
/// key is refused with its name. Keys left out keep `can`'s values.
void ReadCanPortSection(const config::Field& section, CanPortConfig& can,
                        CanMediumKey medium = CanMediumKey::kOptional);

/// One key of that section and its `--list-devices` line (the key below the section, e.g. "medium").
struct CanPortKey {
  const char* key;
  const char* description;
};
/// The section's keys, in the order of docs/configuration.md.
extern const std::array<CanPortKey, 4> kCanPortKeys;

}  // namespace teleop::fieldbus
