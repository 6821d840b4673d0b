#pragma once

// The reader of `device.hybrid.fieldbus` (docs/configuration.md, docs/hybrid.md "The real rig"): the CAN bus of the
// two CiA 402 drives, the drives, the Modbus brake amplifier and the handle force sensor.

#include <vector>

#include "device/hybrid/hybrid_fieldbus_device.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"

namespace teleop::device::hybrid {

/// Reads `device.hybrid.fieldbus` (a mapping) into `out` (geometry, allocation and origin already set). Errors
/// "FILE:LINE:COL: key 'device.hybrid.fieldbus.x': reason"; ends with HybridFieldbusConfig::Validate().
void ReadHybridFieldbusSection(const config::Field& section, HybridFieldbusRigConfig& out);

/// The fieldbus section's keys (paths below device.hybrid) for DeviceBackend::keys.
std::vector<ConfigKey> HybridFieldbusKeys();

}  // namespace teleop::device::hybrid
