#pragma once

#include <string>

#include "teleop/config/process_config.hpp"

namespace teleop::config {

/// Reads and validates a process config. Unknown keys, missing required keys, wrong types and out-of-range values
/// throw teleop::Error with "FILE:LINE:COLUMN: key 'a.b.c': reason".
ProcessConfig LoadProcessConfig(const std::string& path);
/// Same, from YAML text; `name` stands in for the file name in messages.
ProcessConfig ParseProcessConfig(const std::string& yaml_text, const std::string& name);

}  // namespace teleop::config
