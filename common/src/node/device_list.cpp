#include "teleop/node/device_list.hpp"

#include <sstream>

#include "teleop/device/device_registry.hpp"

namespace teleop::node {

std::string DescribeDevices() {
  std::ostringstream out;
  const std::vector<std::string> names = device::RegisteredDevices();
  out << names.size() << " device backend" << (names.size() == 1 ? "" : "s") << " registered:\n";
  for (const std::string& name : names) {
    const device::DeviceBackend* b = device::FindDevice(name);
    if (b == nullptr) continue;
    const device::Capabilities& c = b->nominal;
    out << "\n" << name << ": " << b->description << "\n";
    out << "  renders:  " << device::ToString(c.rendering) << (c.has_brake ? ", with a brake" : "") << "\n";
    out << "  sensors:  position" << (c.measures_velocity ? ", velocity" : "")
        << (c.measures_force ? ", handle/tool force" : "") << "\n";
    out << "  section:  device." << name << (b->section_required ? " (required)" : " (optional)") << "\n";
    for (const device::ConfigKey& key : b->keys) {
      out << "    " << key.key << ": " << key.description << "\n";
    }
  }
  return out.str();
}

}  // namespace teleop::node
