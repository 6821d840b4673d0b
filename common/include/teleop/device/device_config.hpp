#pragma once

#include <any>
#include <string>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::device {

/// Per-rig device selection, read from the `device:` section (docs/configuration.md): the backend's registry name,
/// the process's DOF, and the backend's own parsed section (`device.<backend>:`), type-erased. The registered
/// reader of the backend fills `section` (teleop/device/device_registry.hpp); its factory and model read it back
/// with Section<T>().
struct DeviceConfig {
  std::string backend = "loopback";
  int dof = 1;       ///< Authoritative: a backend sizes its device from it.
  std::any section;  ///< The backend's parsed settings (a copyable struct of the backend's choosing); may be empty.

  /// The parsed section as the backend's type. Throws teleop::Error when it holds another type or nothing.
  template <class T>
  const T& Section() const {
    const T* value = std::any_cast<T>(&section);
    if (value == nullptr) {
      throw Error("device: backend '" + backend + "' got a config section of another type (or none); build the " +
                  "DeviceConfig with the backend's reader or its own helper");
    }
    return *value;
  }

  /// A config for `backend` with an already parsed section (tests, programs that build configs in code).
  template <class T>
  static DeviceConfig Of(std::string backend, int dof, T section_value) {
    DeviceConfig c;
    c.backend = std::move(backend);
    c.dof = dof;
    c.section = std::move(section_value);
    return c;
  }
};

}  // namespace teleop::device
