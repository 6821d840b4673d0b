// The toy check of the out-of-tree backend: created by name through MakeDevice and run in the loop's order.
// spring_master.cpp is the real path: the same backend under teleop-master's ProcessMain.
#include <cmath>
#include <cstdio>

#include "teleop/device/device.hpp"
#include "teleop/device/device_registry.hpp"

int main() {
  // spring_device.cpp registered example-spring before main() (TELEOP_REGISTER_DEVICE).
  std::printf("registered backends:");
  for (const auto& name : teleop::device::RegisteredDevices()) std::printf(" %s", name.c_str());
  std::printf("\n");

  teleop::device::DeviceConfig config;
  config.backend = "example-spring";
  config.dof = 1;
  auto device = teleop::device::MakeDevice(config);
  teleop::device::Reading reading;
  const auto command = teleop::device::Command::Force(teleop::DofVector::Constant(1, 1.0));
  for (int cycle = 0; cycle < 2000; ++cycle) {  // 2 s at 1 kHz, the loop's order: Read, Write, Update
    device->Read(reading);
    device->Write(command);
    device->Update(1e-3);
  }
  device->Read(reading);
  // 1 N against 100 N/m settles at 10 mm.
  std::printf("%s: x = %.4f mm after 2 s under 1 N (spring 100 N/m: 10 mm expected)\n", device->name().c_str(),
              reading.position_m[0] * 1e3);
  return std::abs(reading.position_m[0] - 0.01) < 1e-4 ? 0 : 1;
}
