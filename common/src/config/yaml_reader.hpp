#pragma once

// The reader became public: teleop/config/yaml_reader.hpp (library teleop::config_reader). This include keeps
// working for sources that still use the old private path.
#include "teleop/config/yaml_reader.hpp"  // IWYU pragma: export
