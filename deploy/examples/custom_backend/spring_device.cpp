// A custom device backend registered from outside the tree: a 1-DOF mass on a spring, simulated. A real backend
// would open its bus in Configure(), enable its drives in Activate() and exchange frames in Read/Write/Update
// (teleop/device/device.hpp). Its registration (teleop/device/device_registry.hpp, at the end of this file) gives the
// name, a one-line description, the reader of its `device.example-spring` section, the factory and its stability
// model. Compiled into an executable, the object registers itself before main() runs.
#include <any>
#include <memory>
#include <string>
#include <utility>

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
    out.rendered_force_N = teleop::DofVector::Constant(caps_.dof, force_N_);
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

teleop::device::DeviceBackend SpringBackend() {
  teleop::device::DeviceBackend backend;
  backend.name = "example-spring";
  backend.description = "a simulated 1-DOF mass on a spring (out-of-tree example)";
  backend.section_required = false;  // no settings of its own
  backend.read = [](const teleop::config::Field*, const teleop::device::SectionContext&) { return std::any{}; };
  backend.make = [](const teleop::device::DeviceConfig& config) -> std::unique_ptr<teleop::device::Device> {
    return std::make_unique<SpringDevice>(config.dof);
  };
  backend.model = [](const teleop::device::DeviceConfig& config) {
    return teleop::device::AnalysisModel::Uniform(config.dof, 0.05, 2.0);
  };
  return backend;
}

}  // namespace

TELEOP_REGISTER_DEVICE(example_spring, SpringBackend())
