// The `device:` section; the backend's own section is read by its registered reader.

#include <optional>
#include <string>
#include <vector>

#include "sections.hpp"
#include "teleop/device/device_registry.hpp"

namespace teleop::config::sections {

void ParseDevice(const Field& f, Role role, int dof, device::DeviceConfig& device) {
  std::vector<std::string> allowed{"backend"};
  for (const std::string& name : device::RegisteredDevices()) allowed.push_back(name);
  const Map map(f, allowed);
  const Field backend_field = map.Required("backend");
  device.backend = backend_field.AsString();
  device.dof = dof;
  const device::DeviceBackend* backend = device::FindDevice(device.backend);
  if (backend == nullptr) backend_field.Fail(device::UnknownBackendMessage(device.backend));
  for (const std::string& name : device::RegisteredDevices()) {
    if (name == device.backend) continue;
    if (auto other = map.Optional(name)) {
      other->Fail("a section for backend '" + name + "', but backend is '" + device.backend + "'; remove it");
    }
  }
  std::optional<Field> section = map.Optional(device.backend);
  if (!section && backend->section_required) map.Required(device.backend);  // fails with the key's name
  device.section = backend->read(section ? &*section : nullptr, device::SectionContext{role, dof});
}

}  // namespace teleop::config::sections
