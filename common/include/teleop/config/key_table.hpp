#pragma once

#include <string>

#include "teleop/config/key_spec.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/types.hpp"

namespace teleop::config {

/// The key's last path element (what the section's Map holds).
std::string LeafOf(const KeySpec& spec);
/// One line for `--list-devices`: "number, kg, > 0, required: Device mass per DOF. ...".
std::string DescribeKey(const KeySpec& spec);
/// Its docs row: "| `mass_kg` | number, kg | **required** | > 0 | Device mass per DOF. ... |".
std::string KeyTableRow(const KeySpec& spec);
/// Reads a kNumber key from `map`: required (a missing key is an error at the section) or its default, checked
/// against its range with its unit in the message.
double ReadNumber(const Map& map, const KeySpec& spec);
/// Reads a kInteger key: required or its default, in [low, high].
int ReadInteger(const Map& map, const KeySpec& spec);
/// Reads a kDofValue key: `dof` entries, each checked against the range; absent: the default on every DOF.
DofVector ReadDofValue(const Map& map, const KeySpec& spec, int dof);

}  // namespace teleop::config
