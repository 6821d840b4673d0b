// A custom device backend registered from outside the tree: a 1-DOF mass on a spring, simulated. A real backend
// would open its bus in the constructor and exchange frames in Read/Write/Update (teleop/device/device.hpp).
#include <any>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "teleop/device/device.hpp"
#include "teleop/device/device_registry.hpp"

namespace {

class SpringDevice final : public teleop::device::Device {
 public:
  explicit SpringDevice(int dof) { caps_.dof = dof; }
  const teleop::device::Capabilities& capabilities() const noexcept override { return caps_; }
  const std::string& name() const noexcept override { return name_; }
  void Read(teleop::device::Reading& out) noexcept override {
    out.position_m = teleop::DofVector::Constant(caps_.dof, x_m_);
    out.velocity_m_per_s = teleop::DofVector::Constant(caps_.dof, v_m_per_s_);
    out.force_N = teleop::ZeroDof(caps_.dof);
    out.faults = teleop::device::kFaultNone;
  }
  void Write(const teleop::device::Command& command) noexcept override { force_N_ = command.force_N[0]; }
  void Update(double period_s) noexcept override {  // semi-implicit Euler: m a = F - k x - b v
    const double a = (force_N_ - kStiffness_N_per_m * x_m_ - kDamping_Ns_per_m * v_m_per_s_) / kMass_kg;
    v_m_per_s_ += a * period_s;
    x_m_ += v_m_per_s_ * period_s;
  }
  void SetSafe() noexcept override { force_N_ = 0.0; }

 private:
  static constexpr double kMass_kg = 0.05;
  static constexpr double kStiffness_N_per_m = 100.0;
  static constexpr double kDamping_Ns_per_m = 2.0;
  teleop::device::Capabilities caps_{};
  std::string name_ = "example-spring";
  double x_m_ = 0.0;
  double v_m_per_s_ = 0.0;
  double force_N_ = 0.0;
};

}  // namespace

int main() {
  teleop::device::DeviceBackend backend;
  backend.name = "example-spring";
  backend.description = "a simulated 1-DOF mass on a spring (out-of-tree example)";
  backend.section_required = false;  // no device.example-spring section: nothing to read
  backend.read = [](const teleop::config::Field* /*section*/, const teleop::device::SectionContext& /*context*/) {
    return std::any{};
  };
  backend.make = [](const teleop::device::DeviceConfig& config) { return std::make_unique<SpringDevice>(config.dof); };
  teleop::device::RegisterDevice(std::move(backend));
  std::printf("registered backends:");
  for (const auto& name : teleop::device::RegisteredDevices()) std::printf(" %s", name.c_str());
  std::printf("\n");

  teleop::device::DeviceConfig config;
  config.backend = "example-spring";
  config.dof = 1;
  auto device = teleop::device::MakeDevice(config);
  device->Configure();
  device->Activate();
  teleop::device::Reading reading;
  const teleop::device::Command command = teleop::device::Command::Force(teleop::DofVector::Constant(1, 1.0));
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
