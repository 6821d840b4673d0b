#pragma once

// The node's names for the `engagement:` and `safety:` sections, which live in the config layer
// (teleop/config/engagement_config.hpp): config sits below node and includes no node header.

#include "teleop/config/engagement_config.hpp"

namespace teleop::node {

using config::EngagementConfig;
using config::Reaction;
using config::SafetyConfig;
using config::ToString;

}  // namespace teleop::node
