// device.hybrid with rig: fieldbus, read from YAML: the shipped real-rig config, and refusals with the key named.
#include <gtest/gtest.h>

#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "device/hybrid/hybrid_device.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"

namespace teleop::device::hybrid {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

std::string ShippedConfig() {
  std::ifstream in(std::string(TELEOP_SOURCE_DIR) + "/deploy/configs/hybrid/master-fieldbus.yaml");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(HybridFieldbusConfig, TheShippedRealRigConfigSelectsTheFieldbusRig) {
  const std::string text = ShippedConfig();
  ASSERT_FALSE(text.empty());
  const auto config = config::ParseProcessConfig(text, "master-fieldbus.yaml");
  const auto& c = config.device.Section<HybridDeviceConfig>();
  ASSERT_TRUE(c.fieldbus_rig);
  const HybridFieldbusConfig& d = c.fieldbus.device;
  EXPECT_EQ(c.fieldbus.can.medium, transport::CanMedium::kEmulatedBus);
  EXPECT_EQ(c.fieldbus.can.emulated_bus_port, 47300);
  EXPECT_EQ(d.drives[0].node_id, 1);
  EXPECT_EQ(d.drives[1].node_id, 2);
  EXPECT_FALSE(d.drives[0].produce_sync || d.drives[1].produce_sync);
  EXPECT_NEAR(d.joint_offset_rad[0], 30.0 * kDeg, 1e-12);
  EXPECT_NEAR(d.joint_offset_rad[1], 150.0 * kDeg, 1e-12);
  EXPECT_DOUBLE_EQ(d.drives[0].max_torque_Nm, 0.888);
  EXPECT_DOUBLE_EQ(d.origin_m.y(), 0.20);
  EXPECT_EQ(d.force_sensor, ForceSensorBus::kCan);
  EXPECT_EQ(d.can_force_sensor.cob_id, 0x190u);
  EXPECT_EQ(d.amplifier.tcp.port, 1502);
  EXPECT_EQ(d.amplifier.outputs.size(), 2u);
  EXPECT_DOUBLE_EQ(d.allocation.brake.max_torque_Nm, 4.0);
  // Built without I/O (the ports open at Configure), with the hybrid's capabilities.
  const auto device = MakeDevice(config.device);
  EXPECT_EQ(device->capabilities().dof, 2);
  EXPECT_TRUE(device->capabilities().has_brake);
}

/// The shipped config with `from` replaced by `to`; the error must name `key` and say `reason`.
void ExpectRefused(const std::string& from, const std::string& to, const std::string& key, const std::string& reason) {
  std::string text = ShippedConfig();
  const auto at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
  try {
    (void)config::ParseProcessConfig(text, "rig.yaml");
    ADD_FAILURE() << "accepted: " << to;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("rig.yaml:"), std::string::npos) << what;
    EXPECT_NE(what.find(key), std::string::npos) << what;
    EXPECT_NE(what.find(reason), std::string::npos) << what;
  }
}

TEST(HybridFieldbusConfig, BadValuesAreRefusedWithTheirKey) {
  ExpectRefused("rig: fieldbus", "rig: real", "device.hybrid.rig", "simulated or fieldbus");
  ExpectRefused("medium: emulated", "medium: ethercat", "device.hybrid.fieldbus.can.medium", "socketcan or emulated");
  ExpectRefused("bus: \"127.0.0.1:47300\"", "bus: \"127.0.0.1\"", "device.hybrid.fieldbus.can.bus", "HOST:PORT");
  ExpectRefused("- node_id: 2", "- node_id: 1", "device.hybrid.fieldbus.drives", "node_id must differ");
  ExpectRefused("- node_id: 1", "- node_id: 128", "device.hybrid.fieldbus.drives[0].node_id", "");
  ExpectRefused("cob_id: 0x190", "cob_id: 0x080", "device.hybrid.fieldbus.force_sensor.cob_id", "SYNC");
  ExpectRefused("bus: can\n", "bus: ethercat\n", "device.hybrid.fieldbus.force_sensor.bus", "modbus or can");
  ExpectRefused("scale: 0.001, safe_value: 4.0}", "scale: 0.001, safe_value: 0.0}", "device.hybrid.fieldbus",
                "safe_value");
  ExpectRefused("stale_after_ms: 20\n        - node_id: 2", "stale_after_ms: 1\n        - node_id: 2",
                "device.hybrid.fieldbus.drives[0].stale_after_ms", "two cycles");
  ExpectRefused("bus: can\n", "bus: modbus\n", "device.hybrid.fieldbus.force_sensor", "");  // extra CAN keys
  ExpectRefused("rig: fieldbus", "rig: fieldbus\n    operator: {speed_m_per_s: 0.1}", "device.hybrid.operator",
                "simulated rig");
  ExpectRefused("rig: fieldbus", "rig: simulated", "device.hybrid.fieldbus", "rig: fieldbus");
}

TEST(HybridFieldbusConfig, ModbusForceSensorNeedsItsInputs) {
  std::string text = ShippedConfig();
  const std::string sensor = text.substr(text.find("      force_sensor:"));
  const std::string modbus_sensor = "      force_sensor: {bus: modbus}\n      activate_timeout_ms: 2000\n";
  const auto end =
      sensor.find("      activate_timeout_ms: 2000\n") + std::string("      activate_timeout_ms: 2000\n").size();
  text.replace(text.find("      force_sensor:"), end, modbus_sensor);
  try {
    (void)config::ParseProcessConfig(text, "rig.yaml");
    ADD_FAILURE() << "a Modbus force sensor without inputs was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("force_x_N"), std::string::npos) << e.what();
  }
  const std::string inputs =
      "        inputs:\n"
      "          - {name: force_x_N, table: input_register, address: 0, type: int16, scale: 0.01}\n"
      "          - {name: force_y_N, table: input_register, address: 1, type: int16, scale: 0.01}\n";
  text.insert(text.find("      force_sensor: {bus: modbus}"), inputs);
  const auto config = config::ParseProcessConfig(text, "rig.yaml");
  EXPECT_EQ(config.device.Section<HybridDeviceConfig>().fieldbus.device.force_sensor, ForceSensorBus::kModbus);
}

}  // namespace
}  // namespace teleop::device::hybrid
