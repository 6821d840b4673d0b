#pragma once

#include <any>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "teleop/config/key_spec.hpp"
#include "teleop/device/device.hpp"
#include "teleop/device/device_config.hpp"
#include "teleop/types.hpp"

namespace teleop::config {
class Field;  // teleop/config/yaml_reader.hpp (library teleop::config_reader)
}  // namespace teleop::config

namespace teleop::device {

/// One key of a backend's config section, for docs/configuration.md (a test checks every listed key is documented)
/// and `--list-devices`.
struct ConfigKey {
  std::string key;          ///< Path below `device.<backend>`, e.g. "mass_kg", "operator.script[].type".
  std::string description;  ///< One line: meaning, unit, range, default.
};

/// What a section reader knows about the process it reads for.
struct SectionContext {
  Role role = Role::kMaster;
  int dof = 1;
};

/// The device as the start-up stability check sees it (docs/stability.md): mass and damping per axis, the device
/// alone (no operator, no environment). Or "not applicable", with the reason the check prints instead of a verdict
/// (for example a passive, brake-only device, or a cobot that renders no force along the fixture normal).
struct AnalysisModel {
  bool applicable = true;
  std::string reason;          ///< Why the check does not apply (when !applicable).
  DofVector mass_kg;           ///< Per axis (kg), > 0.
  DofVector damping_Ns_per_m;  ///< Per axis (N·s/m), ≥ 0.

  static AnalysisModel Uniform(int dof, double mass_kg, double damping_Ns_per_m);
  static AnalysisModel NotApplicable(std::string reason);
};

/// One configuration of a device whose model depends on its configuration (an arm), as the start-up check's sweep
/// over the configurations where a fixture plane can be reached sees it (docs/arms.md, "Stability").
struct AnalysisConfiguration {
  double mass_kg = 0.0;           ///< Along the plane's normal (kg), > 0.
  double damping_Ns_per_m = 0.0;  ///< Along the plane's normal (N·s/m), ≥ 0.
  std::string where;              ///< The configuration in words: "q = (…) rad, tool at (…) m".
  int represents = 1;             ///< How many sampled configurations it stands for (its bucket).
};

/// The device's models along one fixture plane's normal over the configurations where the plane can be reached.
struct AnalysisSweep {
  std::string summary;  ///< What was sampled and kept, in words (for the check's messages).
  std::vector<AnalysisConfiguration> configurations;
};

/// The device along a unit direction `normal` (in the frame of the positions it reports) at a configuration its
/// Device::configuration_mailbox published: mass_kg +inf when it cannot move along it there. Off the real-time thread
/// only; one caller at a time (it may hold the model it evaluates with). Throws teleop::Error on a configuration of
/// the wrong size.
using ConfigurationModel =
    std::function<AnalysisConfiguration(const DeviceConfiguration& configuration, const DofVector& normal)>;

/// One backend, registered once, in the backend's own files (common/src/device/<name>/, or an out-of-tree
/// project's): see RegisterDevice and TELEOP_REGISTER_DEVICE.
struct DeviceBackend {
  std::string name;         ///< The `device.backend` value and the section key `device.<name>`.
  std::string description;  ///< One line for `--list-devices`.
  /// What the backend renders in its default configuration (for `--list-devices`; dof 1). The device's own
  /// capabilities() is what the node checks.
  Capabilities nominal{};
  std::vector<ConfigKey> keys;  ///< Every key its reader accepts.
  /// The keys written once in a key table (teleop/config/key_table.hpp): their reader, their `keys` entry and their
  /// docs row come from it (AdoptKeyTable, teleop/device/backend_key_table.hpp). Empty for a backend without one.
  std::vector<config::KeySpec> key_table;
  /// Whether `device.<name>:` must be present. When it is absent and not required, `read` gets nullptr.
  bool section_required = true;
  /// Reads and validates `device.<name>` (errors through config::Field::Fail, "FILE:LINE:COL: key 'a.b': reason";
  /// reader helpers in teleop/config/yaml_reader.hpp). Returns the parsed section for DeviceConfig::section.
  std::function<std::any(const config::Field* section, const SectionContext& context)> read;
  /// Builds the device (validation only; I/O belongs in Device::Configure). Throws teleop::Error.
  std::function<std::unique_ptr<Device>(const DeviceConfig& config)> make;
  /// The device's model for the stability check. Absent: "not applicable, the backend gives no model".
  std::function<AnalysisModel(const DeviceConfig& config)> model;
  /// The device along a fixture plane (unit `normal`, `offset_m`, in the frame of the positions it reports) over
  /// the configurations where the plane can be reached. Absent, or no configurations: the check uses `model` only.
  /// Throws teleop::Error.
  std::function<AnalysisSweep(const DeviceConfig& config, const DofVector& normal, double offset_m)> sweep;
  /// The model at a published configuration, for the run-time limit (config::ConfigurationLimit; docs/arms.md,
  /// "Stability"), built once per process. Absent: the device has no run-time limit.
  std::function<ConfigurationModel(const DeviceConfig& config)> configuration_model;
  /// The run-time limit's options for `config` (`device.<name>.runtime_limit`); absent: off.
  std::function<ConfigurationLimitOptions(const DeviceConfig& config)> configuration_limit;
};

/// Registers a backend (set-up only, thread-safe; callable from static initialisers and from an out-of-tree
/// program's main). Throws teleop::Error for an empty name, a missing reader or factory, or a taken name.
void RegisterDevice(DeviceBackend backend);
/// Registers a backend by the function that describes it, called at the registry's first lookup rather than now
/// (what TELEOP_REGISTER_DEVICE uses: at static-initialisation time the constants a description reads, such as its
/// key table, may not be initialised yet). The builder's errors (a taken name, ...) are thrown by that lookup.
void RegisterDeviceBuilder(DeviceBackend (*build)());
/// The registered backend called `name`, or nullptr. The pointer stays valid for the program's lifetime.
const DeviceBackend* FindDevice(std::string_view name);
/// Creates the configured backend; throws teleop::Error naming the known backends when `backend` is unknown, and
/// when the factory returns nothing or a device of another DOF. Errors from the backend's validation propagate.
std::unique_ptr<Device> MakeDevice(const DeviceConfig& config);
/// The backend's stability model for `config` (NotApplicable when it registered none). Throws for an unknown
/// backend.
AnalysisModel DeviceModel(const DeviceConfig& config);
/// Names of the registered backends, sorted.
std::vector<std::string> RegisteredDevices();
/// The message for an unknown backend: the name, a "did you mean", and the registered names.
std::string UnknownBackendMessage(std::string_view name);

}  // namespace teleop::device

/// Registers a backend from its own .cpp at static-initialisation time (at namespace scope):
///   TELEOP_REGISTER_DEVICE(loopback, teleop::device::LoopbackBackend())
/// It defines the symbol `teleop_device_backend_<id>`. The object file must reach the program: for an in-tree
/// backend (`id` = its folder name) teleop::devices passes `-Wl,--undefined=teleop_device_backend_<id>`, so the
/// linker takes that object out of the static library (common/src/device/CMakeLists.txt). An out-of-tree backend
/// compiled into the executable registers the same way, or calls RegisterDevice from main.
#define TELEOP_REGISTER_DEVICE(id, backend_expression)                                                               \
  extern "C" {                                                                                                       \
  extern const bool teleop_device_backend_##id;                                                                      \
  const bool teleop_device_backend_##id = [] {                                                                       \
    ::teleop::device::RegisterDeviceBuilder([]() -> ::teleop::device::DeviceBackend { return backend_expression; }); \
    return true;                                                                                                     \
  }();                                                                                                               \
  }
