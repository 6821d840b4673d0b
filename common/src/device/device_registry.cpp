#include "teleop/device/device_registry.hpp"

#include <map>
#include <mutex>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::device {
namespace {

std::unique_ptr<Device> MakeLoopback(const DeviceConfig& config) {
  LoopbackPlantConfig plant = config.loopback;
  plant.dof = config.dof;
  return std::make_unique<LoopbackPlant>(plant);
}

struct Registry {
  Registry() { factories.emplace("loopback", &MakeLoopback); }
  std::mutex mutex;
  std::map<std::string, DeviceFactory> factories;  // sorted by name
};

Registry& TheRegistry() {
  static Registry registry;  // function-local: built on first use, no static-initialisation-order issues
  return registry;
}

std::string KnownNames(const Registry& registry) {
  std::string names;
  for (const auto& [name, factory] : registry.factories) {
    if (!names.empty()) names += ", ";
    names += name;
  }
  return names;
}

}  // namespace

void RegisterDevice(const std::string& name, DeviceFactory factory) {
  if (name.empty()) throw Error("device registry: a backend needs a non-empty name");
  if (!factory) throw Error("device registry: backend '" + name + "' was registered without a factory");
  Registry& registry = TheRegistry();
  const std::lock_guard<std::mutex> lock(registry.mutex);
  if (!registry.factories.emplace(name, std::move(factory)).second) {
    throw Error("device registry: backend '" + name + "' is already registered; pick another name");
  }
}

std::unique_ptr<Device> MakeDevice(const DeviceConfig& config) {
  DeviceFactory factory;
  {
    Registry& registry = TheRegistry();
    const std::lock_guard<std::mutex> lock(registry.mutex);
    const auto it = registry.factories.find(config.backend);
    if (it == registry.factories.end()) {
      throw Error("device: unknown backend '" + config.backend + "'; known backends: " + KnownNames(registry));
    }
    factory = it->second;
  }
  std::unique_ptr<Device> device = factory(config);
  if (!device) throw Error("device: backend '" + config.backend + "' failed to create a device");
  return device;
}

std::vector<std::string> RegisteredDevices() {
  Registry& registry = TheRegistry();
  const std::lock_guard<std::mutex> lock(registry.mutex);
  std::vector<std::string> names;
  names.reserve(registry.factories.size());
  for (const auto& [name, factory] : registry.factories) names.push_back(name);
  return names;
}

}  // namespace teleop::device
