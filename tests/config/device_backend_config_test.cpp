// A second backend, registered from this test's own file exactly as an out-of-tree backend would be (the
// TELEOP_REGISTER_DEVICE macro in a translation unit of the program), is read from YAML, built, checked for what it
// can render, and told apart by the stability check — without any change to a central file.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>

#include "teleop/config/render_check.hpp"
#include "teleop/config/stability_check.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "test_utilities/config_text.hpp"

namespace teleop {
namespace {

using ::testing::HasSubstr;

/// The test backend's section: a brake-only device (dissipative only), one brake force per axis.
struct TestBrakeSection {
  DofVector max_brake_force_N;
  double mass_kg = 0.0;
};

/// A passive brake device: it renders only resistance, never pushes; Write clamps nothing (records the command).
class TestBrake final : public device::Device {
 public:
  explicit TestBrake(const device::DeviceConfig& config) : section_(config.Section<TestBrakeSection>()) {
    caps_.dof = config.dof;
    caps_.rendering = device::Rendering::kDissipativeOnly;
    caps_.max_force_N = DofVector::Zero(config.dof);
    caps_.has_brake = true;
    caps_.max_brake_force_N = section_.max_brake_force_N;
    position_m_ = DofVector::Zero(config.dof);
  }
  const device::Capabilities& capabilities() const noexcept override { return caps_; }
  const std::string& name() const noexcept override { return name_; }
  void Read(device::Reading& out) noexcept override {
    out.position_m = position_m_;
    out.velocity_m_per_s = position_m_;
    out.force_N = position_m_;
    out.rendered_force_N = position_m_;
    out.faults = device::kFaultNone;
  }
  void Write(const device::Command& /*command*/) noexcept override {}
  void Update(double /*period_s*/) noexcept override {}
  void SetSafe() noexcept override {}

 private:
  TestBrakeSection section_;
  device::Capabilities caps_{};
  std::string name_ = "test-brake";
  DofVector position_m_;
};

device::DeviceBackend TestBrakeBackend() {
  device::DeviceBackend b;
  b.name = "test-brake";
  b.description = "a brake-only device for the registry tests";
  b.nominal.rendering = device::Rendering::kDissipativeOnly;
  b.nominal.has_brake = true;
  b.keys = {{"max_brake_force_N", "largest brake force per axis (N), > 0"}, {"mass_kg", "moving mass (kg), > 0"}};
  b.read = [](const config::Field* section, const device::SectionContext& context) -> std::any {
    TestBrakeSection s;
    if (section == nullptr) {  // optional section: defaults
      s.max_brake_force_N = DofVector::Constant(context.dof, 5.0);
      s.mass_kg = 0.1;
      return s;
    }
    const config::Map map(*section, {"max_brake_force_N", "mass_kg"});
    s.max_brake_force_N = config::ReadDofVector(map.Required("max_brake_force_N"), context.dof,
                                                [](const config::Field& f) { return config::Positive(f, "N"); });
    s.mass_kg = 0.1;
    if (auto v = map.Optional("mass_kg")) s.mass_kg = config::Positive(*v, "kg");
    return s;
  };
  b.section_required = false;
  b.make = [](const device::DeviceConfig& config) -> std::unique_ptr<device::Device> {
    return std::make_unique<TestBrake>(config);
  };
  b.model = [](const device::DeviceConfig&) {
    return device::AnalysisModel::NotApplicable("a brake only dissipates; it cannot destabilise the fixture");
  };
  return b;
}

}  // namespace
}  // namespace teleop

TELEOP_REGISTER_DEVICE(test_brake, teleop::TestBrakeBackend())

namespace teleop {
namespace {

constexpr const char* kBrakeConfig = R"(role: master
dof: 2
rate_hz: 1000
link:
  security: {mode: insecure}
  bind: "127.0.0.1:47001"
  peer: "127.0.0.1:47002"
law:
  kp_N_per_m: 0
  kd_Ns_per_m: 0
  kv_Ns_per_m: 1.5
fixture:
  stiffness_N_per_m: 800
  half_space: {axis: 0, offset_m: 0.01}
device:
  backend: test-brake
  test-brake:
    max_brake_force_N: [4, 6]
    mass_kg: 0.2
)";

TEST(DeviceBackendConfig, ASecondBackendIsReadFromYamlAndBuilt) {
  const auto names = device::RegisteredDevices();
  ASSERT_NE(std::find(names.begin(), names.end(), "test-brake"), names.end());
  const config::ProcessConfig c = config::ParseProcessConfig(kBrakeConfig, "test.yaml");
  EXPECT_EQ(c.device.backend, "test-brake");
  EXPECT_EQ(c.device.dof, 2);
  const auto& section = c.device.Section<TestBrakeSection>();
  EXPECT_EQ(section.max_brake_force_N[1], 6.0);
  EXPECT_EQ(section.mass_kg, 0.2);
  const auto device = device::MakeDevice(c.device);
  EXPECT_EQ(device->name(), "test-brake");
  EXPECT_EQ(device->capabilities().max_brake_force_N[0], 4.0);
  // Damping and a fixture are what a brake can render: nothing to refuse.
  EXPECT_TRUE(config::RenderProblems(c, device->capabilities(), device->name()).empty());
}

TEST(DeviceBackendConfig, AnOptionalSectionMayBeLeftOut) {
  const std::string text =
      test::Replace(kBrakeConfig, "  test-brake:\n    max_brake_force_N: [4, 6]\n    mass_kg: 0.2\n", "");
  const config::ProcessConfig c = config::ParseProcessConfig(text, "test.yaml");
  EXPECT_EQ(c.device.Section<TestBrakeSection>().max_brake_force_N[0], 5.0);
}

TEST(DeviceBackendConfig, ItsErrorsAreLocatedLikeTheRestOfTheConfig) {
  test::ExpectError(test::Replace(kBrakeConfig, "mass_kg: 0.2", "mas_kg: 0.2"), "mas_kg", "device.test-brake.mas_kg",
                    "unknown key (did you mean 'mass_kg'?)");
  test::ExpectError(test::Replace(kBrakeConfig, "[4, 6]", "[4, -6]"), "-6", "device.test-brake.max_brake_force_N[1]",
                    "must be > 0 N");
  test::ExpectError(test::Replace(kBrakeConfig, "[4, 6]", "[4, 6, 8]"), "[4, 6, 8]",
                    "device.test-brake.max_brake_force_N", "exactly 2 numbers");
}

TEST(DeviceBackendConfig, UnknownBackendAndForeignSectionsAreNamed) {
  test::ExpectError(test::Replace(kBrakeConfig, "backend: test-brake", "backend: test-brak"), "test-brak",
                    "device.backend", "unknown backend 'test-brak' (did you mean 'test-brake'?)");
  const std::string with_loopback = test::Replace(kBrakeConfig, "    mass_kg: 0.2\n",
                                                  "    mass_kg: 0.2\n  loopback: {mass_kg: 1, damping_Ns_per_m: 0}\n");
  test::ExpectError(with_loopback, "{mass_kg: 1", "device.loopback", "a section for backend 'loopback'");
}

TEST(DeviceBackendConfig, ActiveGainsOnADeviceThatCannotPushAreRefusedByKey) {
  const config::ProcessConfig c =
      config::ParseProcessConfig(test::Replace(kBrakeConfig, "kp_N_per_m: 0", "kp_N_per_m: 600"), "brake.yaml");
  const auto device = device::MakeDevice(c.device);
  const auto problems = config::RenderProblems(c, device->capabilities(), device->name());
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_THAT(problems[0], HasSubstr("key 'law.kp_N_per_m'"));
  EXPECT_THAT(problems[0], HasSubstr("dissipative only"));
  try {
    config::RequireRenderable(c, device->capabilities(), device->name());
    FAIL() << "a brake-only device accepted an active position gain";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("brake.yaml: the device cannot render this config"));
    EXPECT_THAT(e.what(), HasSubstr("law.kp_N_per_m"));
  }
}

TEST(DeviceBackendConfig, TheStabilityCheckPrintsTheBackendsReasonInsteadOfAVerdict) {
  const config::ProcessConfig c = config::ParseProcessConfig(kBrakeConfig, "test.yaml");
  const config::StabilityReport report = config::CheckProcessStability(c);
  EXPECT_FALSE(report.applicable());
  EXPECT_TRUE(report.stable());  // nothing found to refuse
  EXPECT_TRUE(report.axes.empty());
  const std::string line = config::DescribePass(c, report);
  EXPECT_THAT(line, HasSubstr("not applicable"));
  EXPECT_THAT(line, HasSubstr("a brake only dissipates"));
  EXPECT_THROW((void)config::StabilityModel(c, 0), Error);
  // Both stability.device keys make it checkable against that mass-damper.
  const std::string with_model =
      kBrakeConfig + std::string("stability:\n  device: {mass_kg: 0.2, damping_Ns_per_m: 0.5}\n");
  const config::ProcessConfig m = config::ParseProcessConfig(with_model, "test.yaml");
  EXPECT_TRUE(config::StabilityNotApplicable(m).empty());
  EXPECT_EQ(config::StabilityModel(m, 0).master.mass_kg, 0.2);
}

}  // namespace
}  // namespace teleop
