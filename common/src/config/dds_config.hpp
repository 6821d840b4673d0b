#pragma once

// Private to the config library: the `dds:` section (docs/dds.md, docs/configuration.md).

#include "teleop/config/yaml_reader.hpp"
#include "teleop/dds/bridge_config.hpp"

namespace teleop::config::detail {

/// Reads `dds: {enabled, domain_id, pair, state_rate_hz, ring_capacity}`; the state rate must not exceed the loop
/// rate `loop_rate_hz`. Throws teleop::Error located at the offending key.
void ParseDds(const Field& field, double loop_rate_hz, dds::BridgeConfig& dds);

}  // namespace teleop::config::detail
