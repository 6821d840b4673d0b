// The `cobot` backend's registration: the simulated unicycle or bicycle cobot of Colgate et al., or the unicycle on
// CAN (docs/cobot.md, `device.cobot`). The reader is cobot_config_reader.cpp, the devices unicycle_cobot_device.cpp,
// bicycle_cobot_device.cpp and cobot_fieldbus_device.cpp.

#include "device/cobot/cobot_backend.hpp"

#include <memory>
#include <string>

#include "cobot_backend_private.hpp"
#include "cobot_keys.hpp"
#include "device/cobot/cobot_fieldbus_device.hpp"
#include "teleop/device/backend_key_table.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/can_port_yaml.hpp"

namespace teleop::device::cobot {

DeviceBackend CobotBackend() {
  DeviceBackend b;
  b.name = CobotName();
  b.description =
      "cobot (Colgate et al.): a steered wheel renders walls passively; unicycle (x, y) or bicycle (x, y, θ), "
      "simulated or (unicycle) on CAN";
  b.nominal = CobotCapabilities(2, 0.0);
  b.keys = {
      {"virtual_mass_kg",
       "1/K1 of the virtual caster (eq 2) (kg): equal to cart_mass_kg (the default) or refused, one mass in every "
       "direction (unicycle only: the bicycle's is its plate mass)"},
      {"bicycle.hold_heading_deg", "angular constraint: the wheels hold the plate's θ at this (deg); default none"},
      {"fieldbus.can", "the bus: medium, interface or bus"},
  };
  for (const fieldbus::CanPortKey& key : fieldbus::kCanPortKeys) {
    b.keys.push_back({std::string("fieldbus.can.") + key.key, key.description});
  }

  AdoptKeyTable(b, keys::All());  // the keys with a number, a word or true/false, written once (cobot_keys.hpp)
  b.section_required = false;
  b.read = [](const config::Field* section, const SectionContext& context) -> std::any {
    return ReadCobot(section, context.dof, context.role);
  };
  b.make = [](const DeviceConfig& config) -> std::unique_ptr<Device> {
    const CobotBackendConfig c = config.section.has_value() ? config.Section<CobotBackendConfig>()
                                                            : ReadCobot(nullptr, config.dof, Role::kMaster);
    const int expected = c.kind == CobotBackendConfig::Kind::kUnicycle ? 2 : 3;
    if (config.dof != expected) {
      throw Error("device.cobot: this cobot has dof " + std::to_string(expected) + ", the process " +
                  std::to_string(config.dof));
    }
    if (c.kind == CobotBackendConfig::Kind::kBicycle) return std::make_unique<BicycleCobotDevice>(c);
    if (c.rig == CobotBackendConfig::Rig::kFieldbus) return std::make_unique<UnicycleCobotFieldbusDevice>(c);
    return std::make_unique<UnicycleCobotDevice>(c);
  };
  b.model = [](const DeviceConfig&) {
    return AnalysisModel::NotApplicable(
        "a cobot renders no force along the fixture normal: its walls are steered (kinematic), so the force-loop "
        "stability check does not apply; eq 10 of Colgate et al. does (teleop-scenario cobot-stability)");
  };
  return b;
}

DeviceConfig CobotDeviceConfig(const CobotBackendConfig& config) {
  return DeviceConfig::Of("cobot", config.kind == CobotBackendConfig::Kind::kUnicycle ? 2 : 3, config);
}

}  // namespace teleop::device::cobot

TELEOP_REGISTER_DEVICE(cobot, teleop::device::cobot::CobotBackend())
