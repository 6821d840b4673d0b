#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "teleop/device/device.hpp"
#include "teleop/device/loopback_plant.hpp"

namespace teleop::device {

/// Per-rig device selection. `backend` names a registered backend; the matching section holds its settings.
/// Backends added later (hybrid motor–brake, cobot, CAN/Modbus drivers) add their section here.
/// `dof` is authoritative: the loopback factory uses it for the plant (loopback.dof is overwritten).
struct DeviceConfig {
  std::string backend = "loopback";
  int dof = 1;
  LoopbackPlantConfig loopback{};
};

using DeviceFactory = std::function<std::unique_ptr<Device>(const DeviceConfig&)>;

/// Registers a backend under `name` (set-up only, thread-safe). Built-in backends ("loopback") are registered on
/// first use. Throws teleop::Error for an empty name, an empty factory, or a name that is already taken.
void RegisterDevice(const std::string& name, DeviceFactory factory);
/// Creates the configured backend; throws teleop::Error naming the known backends when `backend` is unknown, and
/// when the factory returns nothing. Errors from the backend's own validation propagate (teleop::Error).
std::unique_ptr<Device> MakeDevice(const DeviceConfig& config);
/// Names of the registered backends, sorted.
std::vector<std::string> RegisteredDevices();

}  // namespace teleop::device
