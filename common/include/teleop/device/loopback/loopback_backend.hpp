#pragma once

#include "teleop/device/device_config.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/device/loopback/loopback_plant.hpp"

namespace teleop::device {

/// The `loopback` backend's registration (registered from loopback_backend.cpp): reader of `device.loopback`
/// (a LoopbackPlantConfig), factory (LoopbackPlant) and model (the plant's mass and damping on every axis).
DeviceBackend LoopbackBackend();

/// A DeviceConfig selecting the loopback backend with `plant` (its dof is the config's).
DeviceConfig LoopbackDeviceConfig(const LoopbackPlantConfig& plant);

}  // namespace teleop::device
