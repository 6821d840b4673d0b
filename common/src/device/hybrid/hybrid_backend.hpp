#pragma once

#include "device/hybrid/hybrid_device.hpp"
#include "teleop/device/device_config.hpp"
#include "teleop/device/device_registry.hpp"

namespace teleop::device::hybrid {

/// The `hybrid` backend's registration (registered from hybrid_backend.cpp): reader of `device.hybrid`
/// (a HybridDeviceConfig), factory (HybridDevice, dof 2 only) and model (the handle's effective mass and damping
/// per axis at the initial position).
DeviceBackend HybridBackend();

/// A DeviceConfig selecting the hybrid backend with `config` (dof 2).
DeviceConfig HybridDeviceConfigOf(const HybridDeviceConfig& config);

}  // namespace teleop::device::hybrid
