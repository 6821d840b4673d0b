#pragma once

// Moved to teleop/link/link_config.hpp, next to its source (common/src/link/link_config.cpp); this include keeps
// working for code that has not moved yet.
#include "teleop/link/link_config.hpp"  // IWYU pragma: export
