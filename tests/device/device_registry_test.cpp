// The backend registry: built-in registration through teleop::devices, public registration, lookup and errors.

#include "teleop/device/device_registry.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "teleop/device/loopback.hpp"
#include "teleop/error.hpp"

namespace teleop::device {
namespace {

DeviceBackend Minimal(const std::string& name) {
  DeviceBackend b;
  b.name = name;
  b.read = [](const config::Field*, const SectionContext&) { return std::any{}; };
  b.make = [](const DeviceConfig& config) -> std::unique_ptr<Device> {
    LoopbackPlantConfig plant;
    plant.dof = config.dof;
    return std::make_unique<LoopbackPlant>(plant);
  };
  return b;
}

TEST(DeviceRegistry, LoopbackRegistersItselfThroughTheDevicesLibrary) {
  const DeviceConfig config = LoopbackDeviceConfig(LoopbackPlantConfig::PaperSlave(3));
  const auto device = MakeDevice(config);
  ASSERT_NE(device, nullptr);
  EXPECT_EQ(device->name(), "loopback");
  EXPECT_EQ(device->capabilities().dof, 3);
  EXPECT_EQ(device->capabilities().rendering, Rendering::kActiveForce);
  Reading reading;
  device->Read(reading);
  EXPECT_EQ(reading.position_m.size(), 3);
  const auto names = RegisteredDevices();
  EXPECT_NE(std::find(names.begin(), names.end(), "loopback"), names.end());
  const DeviceBackend* backend = FindDevice("loopback");
  ASSERT_NE(backend, nullptr);
  EXPECT_FALSE(backend->description.empty());
  EXPECT_FALSE(backend->keys.empty());
}

TEST(DeviceRegistry, LoopbackModelIsThePlantsMassAndDamping) {
  const AnalysisModel model = DeviceModel(LoopbackDeviceConfig(LoopbackPlantConfig::PaperMaster(2)));
  ASSERT_TRUE(model.applicable);
  ASSERT_EQ(model.mass_kg.size(), 2);
  EXPECT_EQ(model.mass_kg[1], 0.040);
  EXPECT_EQ(model.damping_Ns_per_m[0], 0.41);
}

TEST(DeviceRegistry, UnknownBackendListsTheKnownOnesWithASuggestion) {
  DeviceConfig config;
  config.backend = "loopbak";
  try {
    (void)MakeDevice(config);
    FAIL() << "unknown backend accepted";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("'loopbak'"), std::string::npos) << message;
    EXPECT_NE(message.find("did you mean 'loopback'"), std::string::npos) << message;
  }
}

TEST(DeviceRegistry, RegisterACustomBackend) {
  int created = 0;
  DeviceBackend b = Minimal("test-double");
  b.make = [&created](const DeviceConfig& config) -> std::unique_ptr<Device> {
    ++created;
    LoopbackPlantConfig plant;
    plant.dof = config.dof;
    return std::make_unique<LoopbackPlant>(plant);
  };
  RegisterDevice(b);
  DeviceConfig config;
  config.backend = "test-double";
  EXPECT_NE(MakeDevice(config), nullptr);
  EXPECT_EQ(created, 1);
  const auto names = RegisteredDevices();
  EXPECT_TRUE(std::is_sorted(names.begin(), names.end()));
  EXPECT_NE(std::find(names.begin(), names.end(), "test-double"), names.end());
  // No model registered: the stability check is told why it cannot apply.
  const AnalysisModel model = DeviceModel(config);
  EXPECT_FALSE(model.applicable);
  EXPECT_NE(model.reason.find("test-double"), std::string::npos) << model.reason;

  EXPECT_THROW(RegisterDevice(Minimal("test-double")), Error);  // taken
  EXPECT_THROW(RegisterDevice(Minimal("")), Error);
  DeviceBackend no_factory = Minimal("no-factory");
  no_factory.make = nullptr;
  EXPECT_THROW(RegisterDevice(no_factory), Error);
  DeviceBackend no_reader = Minimal("no-reader");
  no_reader.read = nullptr;
  EXPECT_THROW(RegisterDevice(no_reader), Error);
  DeviceBackend null_factory = Minimal("null-factory");
  null_factory.make = [](const DeviceConfig&) { return std::unique_ptr<Device>{}; };
  RegisterDevice(null_factory);
  config.backend = "null-factory";
  EXPECT_THROW((void)MakeDevice(config), Error);
}

TEST(DeviceRegistry, ADeviceOfAnotherDofIsRefused) {
  DeviceBackend b = Minimal("wrong-dof");
  b.make = [](const DeviceConfig&) -> std::unique_ptr<Device> {
    return std::make_unique<LoopbackPlant>(LoopbackPlantConfig::PaperMaster(2));
  };
  RegisterDevice(b);
  DeviceConfig config;
  config.backend = "wrong-dof";
  config.dof = 3;
  EXPECT_THROW((void)MakeDevice(config), Error);
}

TEST(DeviceRegistry, BackendValidationErrorsPropagate) {
  LoopbackPlantConfig plant;
  plant.mass_kg = -1.0;
  EXPECT_THROW((void)MakeDevice(LoopbackDeviceConfig(plant)), Error);
  DeviceConfig no_section;  // loopback without its parsed section
  EXPECT_THROW((void)MakeDevice(no_section), Error);
}

}  // namespace
}  // namespace teleop::device
