#pragma once

// The YAML reader of a Modbus config section (docs/modbus.md, "Register map"). Errors are teleop::Error with the
// project's "FILE:LINE:COL: key 'a.b': reason" form, unknown keys with a suggestion.

#include <string>

#include "teleop/fieldbus/modbus_config.hpp"

namespace YAML {
class Node;
}

namespace teleop::fieldbus {

/// Reads the section `node` (a mapping) found at key path `path` ("device.hybrid.modbus") of file `file`, then
/// Validate()s the result. Throws teleop::Error.
ModbusConfig ReadModbusConfig(const YAML::Node& node, const std::string& path, const std::string& file);

/// Parses `yaml_text` whose top level is the section itself; `name` is the file name in messages.
ModbusConfig ParseModbusConfig(const std::string& yaml_text, const std::string& name);

}  // namespace teleop::fieldbus
