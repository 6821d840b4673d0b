#include "teleop/device/device_registry.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device {
namespace {

TEST(DeviceRegistry, LoopbackIsBuiltIn) {
  DeviceConfig config;
  config.dof = 3;
  const auto device = MakeDevice(config);
  ASSERT_NE(device, nullptr);
  EXPECT_EQ(device->name(), "loopback");
  EXPECT_EQ(device->capabilities().dof, 3);  // DeviceConfig::dof is authoritative
  Reading reading;
  device->Read(reading);
  EXPECT_EQ(reading.position_m.size(), 3);
  const auto names = RegisteredDevices();
  EXPECT_NE(std::find(names.begin(), names.end(), "loopback"), names.end());
}

TEST(DeviceRegistry, UnknownBackendListsTheKnownOnes) {
  DeviceConfig config;
  config.backend = "warp-drive";
  try {
    (void)MakeDevice(config);
    FAIL() << "unknown backend accepted";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("warp-drive"), std::string::npos) << message;
    EXPECT_NE(message.find("loopback"), std::string::npos) << message;
  }
}

TEST(DeviceRegistry, RegisterACustomBackend) {
  int created = 0;
  RegisterDevice("test-double", [&created](const DeviceConfig& config) -> std::unique_ptr<Device> {
    ++created;
    LoopbackPlantConfig plant;
    plant.dof = config.dof;
    return std::make_unique<LoopbackPlant>(plant);
  });
  DeviceConfig config;
  config.backend = "test-double";
  EXPECT_NE(MakeDevice(config), nullptr);
  EXPECT_EQ(created, 1);
  const auto names = RegisteredDevices();
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end()));
  EXPECT_NE(std::find(names.begin(), names.end(), "test-double"), names.end());
  EXPECT_THROW(RegisterDevice("test-double", [](const DeviceConfig&) { return std::unique_ptr<Device>{}; }), Error);
  EXPECT_THROW(RegisterDevice("", [](const DeviceConfig&) { return std::unique_ptr<Device>{}; }), Error);
  EXPECT_THROW(RegisterDevice("no-factory", DeviceFactory{}), Error);
  RegisterDevice("null-factory", [](const DeviceConfig&) { return std::unique_ptr<Device>{}; });
  config.backend = "null-factory";
  EXPECT_THROW((void)MakeDevice(config), Error);
}

TEST(DeviceRegistry, BackendValidationErrorsPropagate) {
  DeviceConfig config;
  config.loopback.mass_kg = -1.0;
  EXPECT_THROW((void)MakeDevice(config), Error);
}

}  // namespace
}  // namespace teleop::device
