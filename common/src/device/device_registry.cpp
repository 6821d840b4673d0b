#include "teleop/device/device_registry.hpp"

#include <algorithm>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

#include "teleop/closest_match.hpp"
#include "teleop/error.hpp"

namespace teleop::device {
namespace {

struct Registry {
  std::mutex mutex;
  std::map<std::string, DeviceBackend, std::less<>> backends;  // sorted by name; nodes never move
  /// TELEOP_REGISTER_DEVICE's builders, run at the first lookup (after every static initialiser: a backend's
  /// description may read other translation units' constants, e.g. its key table, whose initialisation order
  /// against the registrar's is unspecified).
  std::vector<DeviceBackend (*)()> pending;
};

Registry& TheRegistry() {
  static Registry registry;  // function-local: built on first use, no static-initialisation-order issues
  return registry;
}

const DeviceBackend& Require(std::string_view name) {
  const DeviceBackend* backend = FindDevice(name);
  if (backend == nullptr) throw Error("device: " + UnknownBackendMessage(name));
  return *backend;
}

}  // namespace

const char* ToString(Rendering rendering) noexcept {
  switch (rendering) {
    case Rendering::kActiveForce:
      return "active force";
    case Rendering::kActiveAndDissipative:
      return "active + dissipative (motor and brake)";
    case Rendering::kDissipativeOnly:
      return "dissipative only";
    case Rendering::kSteeredConstraints:
      return "steered constraints";
  }
  return "unknown";
}

AnalysisModel AnalysisModel::Uniform(int dof, double mass_kg, double damping_Ns_per_m) {
  AnalysisModel m;
  m.mass_kg = DofVector::Constant(dof, mass_kg);
  m.damping_Ns_per_m = DofVector::Constant(dof, damping_Ns_per_m);
  return m;
}

AnalysisModel AnalysisModel::NotApplicable(std::string reason) {
  AnalysisModel m;
  m.applicable = false;
  m.reason = std::move(reason);
  return m;
}

namespace {

void AddLocked(Registry& registry, DeviceBackend backend) {
  if (backend.name.empty()) throw Error("device registry: a backend needs a non-empty name");
  const std::string name = backend.name;
  if (!backend.make) throw Error("device registry: backend '" + name + "' was registered without a factory");
  if (!backend.read) throw Error("device registry: backend '" + name + "' was registered without a section reader");
  if (!registry.backends.emplace(name, std::move(backend)).second) {
    throw Error("device registry: backend '" + name + "' is already registered; pick another name");
  }
}

/// Builds the backends registered by builder (with the registry's lock held).
void BuildPendingLocked(Registry& registry) {
  std::vector<DeviceBackend (*)()> pending;
  pending.swap(registry.pending);
  for (DeviceBackend (*build)() : pending) AddLocked(registry, build());
}

}  // namespace

void RegisterDevice(DeviceBackend backend) {
  Registry& registry = TheRegistry();
  const std::lock_guard<std::mutex> lock(registry.mutex);
  BuildPendingLocked(registry);
  AddLocked(registry, std::move(backend));
}

void RegisterDeviceBuilder(DeviceBackend (*build)()) {
  if (build == nullptr) throw Error("device registry: a null backend builder");
  Registry& registry = TheRegistry();
  const std::lock_guard<std::mutex> lock(registry.mutex);
  registry.pending.push_back(build);
}

const DeviceBackend* FindDevice(std::string_view name) {
  Registry& registry = TheRegistry();
  const std::lock_guard<std::mutex> lock(registry.mutex);
  BuildPendingLocked(registry);
  const auto it = registry.backends.find(name);
  return it == registry.backends.end() ? nullptr : &it->second;
}

std::vector<std::string> RegisteredDevices() {
  Registry& registry = TheRegistry();
  const std::lock_guard<std::mutex> lock(registry.mutex);
  BuildPendingLocked(registry);
  std::vector<std::string> names;
  names.reserve(registry.backends.size());
  for (const auto& [name, backend] : registry.backends) names.push_back(name);
  return names;
}

std::string UnknownBackendMessage(std::string_view name) {
  const std::vector<std::string> names = RegisteredDevices();
  std::string message = "unknown backend '" + std::string(name) + "'";
  std::string known;
  for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
  const std::string best = ClosestMatch(name, names);
  if (!best.empty()) message += " (did you mean '" + best + "'?)";
  message += "; registered backends: " + (known.empty() ? std::string("none") : known);
  return message;
}

std::unique_ptr<Device> MakeDevice(const DeviceConfig& config) {
  const DeviceBackend& backend = Require(config.backend);
  std::unique_ptr<Device> device = backend.make(config);
  if (!device) throw Error("device: backend '" + config.backend + "' failed to create a device");
  if (device->capabilities().dof != config.dof) {
    throw Error("device: backend '" + config.backend + "' made a device of " +
                std::to_string(device->capabilities().dof) + " DOF for dof: " + std::to_string(config.dof));
  }
  return device;
}

AnalysisModel DeviceModel(const DeviceConfig& config) {
  const DeviceBackend& backend = Require(config.backend);
  if (!backend.model) {
    return AnalysisModel::NotApplicable("backend '" + config.backend + "' gives no model for the stability check");
  }
  AnalysisModel model = backend.model(config);
  if (model.applicable && (model.mass_kg.size() != config.dof || model.damping_Ns_per_m.size() != config.dof)) {
    throw Error("device: backend '" + config.backend +
                "' gave a stability model of another size than dof: " + std::to_string(config.dof));
  }
  return model;
}

}  // namespace teleop::device
