// The `loopback` backend: the simulated plant of Abbott & Okamura §4.1 (docs/configuration.md, `device.loopback`).

#include <yaml-cpp/yaml.h>

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "loopback_keys.hpp"
#include "teleop/config/key_table.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/backend_key_table.hpp"
#include "teleop/device/loopback.hpp"

namespace teleop::device {
namespace {

using config::Field;
using config::Map;

OperatorSegment ReadSegment(const Field& f, int dof) {
  namespace k = loopback_keys;
  using Kind = OperatorSegment::Kind;
  constexpr std::string_view kPrefix = "operator.script[].";
  // The type first, among the keys of every type; then the keys of this type only (a key of another type is unknown).
  OperatorSegment s;
  s.kind = config::ReadChoiceAs<Kind>(Map(f, config::KeysUnder(k::All(), kPrefix, "*")), k::kSegmentType);
  const Map map(f, config::KeysUnder(k::All(), kPrefix, k::kSegmentType.choices[static_cast<std::size_t>(s.kind)]));
  s.axis = config::ReadInteger(map, k::kSegmentAxis);
  if (s.axis >= dof) map.Required("axis").Fail("must be below dof (" + std::to_string(dof) + ")");
  s.start_s = config::ReadNumber(map, k::kSegmentStart);
  switch (s.kind) {
    case Kind::kHold:
      s.duration_s = config::ReadNumber(map, k::kHoldDuration);
      break;
    case Kind::kStep:
      s.duration_s = config::ReadNumber(map, k::kStepDuration);
      s.to_N = config::ReadNumber(map, k::kStepTo);
      break;
    case Kind::kRamp:
      s.duration_s = config::ReadNumber(map, k::kRampDuration);
      s.from_N = config::ReadNumber(map, k::kRampFrom);
      s.to_N = config::ReadNumber(map, k::kRampTo);
      break;
    case Kind::kSine:
      s.duration_s = config::ReadNumber(map, k::kSineDuration);
      s.amplitude_N = config::ReadNumber(map, k::kSineAmplitude);
      s.frequency_hz = config::ReadNumber(map, k::kSineFrequency);
      s.offset_N = config::ReadNumber(map, k::kSineOffset);
      break;
  }
  return s;
}

void ReadOperator(const Field& f, int dof, SimulatedOperatorConfig& human) {
  std::vector<std::string> keys = config::KeysUnder(loopback_keys::All(), "operator.");
  keys.emplace_back("script");  // a list: its items' keys are the table's operator.script[].* (ReadSegment)
  const Map map(f, keys);
  human.enabled = true;
  human.mass_kg = config::ReadNumber(map, loopback_keys::kOperatorMass);
  human.damping_Ns_per_m = config::ReadNumber(map, loopback_keys::kOperatorDamping);
  human.stiffness_N_per_m = config::ReadNumber(map, loopback_keys::kOperatorStiffness);
  if (auto script = map.Optional("script")) {
    const std::vector<Field> items = script->AsList();
    if (static_cast<int>(items.size()) > SimulatedOperatorConfig::kMaxSegments) {
      script->Fail("at most " + std::to_string(SimulatedOperatorConfig::kMaxSegments) + " segments, got " +
                   std::to_string(items.size()));
    }
    human.segment_count = static_cast<int>(items.size());
    for (std::size_t i = 0; i < items.size(); ++i) human.segments[i] = ReadSegment(items[i], dof);
  }
}

void ReadEnvironment(const Field& f, int dof, SimulatedEnvironmentConfig& env) {
  namespace k = loopback_keys;
  // The type first, among the keys of every type; then the keys of this type only (free: none but type).
  env.kind = config::ReadChoiceAs<SimulatedEnvironmentConfig::Kind>(
      Map(f, config::KeysUnder(k::All(), "environment.", "*")), k::kEnvironmentType);
  const Map map(
      f, config::KeysUnder(k::All(), "environment.", k::kEnvironmentType.choices[static_cast<std::size_t>(env.kind)]));
  if (env.kind != SimulatedEnvironmentConfig::Kind::kWall) return;
  env.axis = config::ReadInteger(map, k::kWallAxis);
  if (env.axis >= dof)
    map.Required(config::LeafOf(k::kWallAxis)).Fail("must be below dof (" + std::to_string(dof) + ")");
  env.position_m = config::ReadNumber(map, k::kWallPosition);
  env.stiffness_N_per_m = config::ReadNumber(map, k::kWallStiffness);
  env.damping_Ns_per_m = config::ReadNumber(map, k::kWallDamping);
}

LoopbackPlantConfig ReadLoopback(const Field& f, int dof) {
  const Map map(f, config::KeysUnder(loopback_keys::All(), ""));
  LoopbackPlantConfig plant;
  plant.dof = dof;
  plant.mass_kg = config::ReadNumber(map, loopback_keys::kMass);
  plant.damping_Ns_per_m = config::ReadNumber(map, loopback_keys::kDamping);
  plant.encoder_resolution_m = config::ReadNumber(map, loopback_keys::kEncoderResolution);
  if (map.Optional("initial_position_m")) {  // absent: empty, the plant starts at 0
    plant.initial_position_m = config::ReadDofValue(map, loopback_keys::kInitialPosition, dof);
  }
  if (auto v = map.Optional(loopback_keys::kOperatorSection.key)) ReadOperator(*v, dof, plant.human);
  if (auto v = map.Optional(loopback_keys::kEnvironmentSection.key)) ReadEnvironment(*v, dof, plant.environment);
  return plant;
}

}  // namespace

DeviceBackend LoopbackBackend() {
  DeviceBackend b;
  b.name = "loopback";
  b.description =
      "simulated mass-damper device with a scripted operator (master) or a wall (slave), Abbott & Okamura §4.1";
  b.nominal.dof = 1;
  b.nominal.rendering = Rendering::kActiveForce;
  b.nominal.measures_velocity = false;
  b.nominal.measures_force = true;
  b.keys = {
      {"operator.script", "list of at most 16 segments of F_h*(t); their keys: operator.script[].*"},
  };
  AdoptKeyTable(b, loopback_keys::All());  // every key but the list operator.script, written once (loopback_keys.hpp)
  b.section_required = true;
  b.read = [](const Field* section, const SectionContext& context) -> std::any {
    return ReadLoopback(*section, context.dof);  // section_required: the config reader checked it is there
  };
  b.make = [](const DeviceConfig& config) -> std::unique_ptr<Device> {
    LoopbackPlantConfig plant = config.Section<LoopbackPlantConfig>();
    plant.dof = config.dof;
    return std::make_unique<LoopbackPlant>(plant);
  };
  b.model = [](const DeviceConfig& config) {
    const LoopbackPlantConfig& plant = config.Section<LoopbackPlantConfig>();
    return AnalysisModel::Uniform(config.dof, plant.mass_kg, plant.damping_Ns_per_m);
  };
  return b;
}

DeviceConfig LoopbackDeviceConfig(const LoopbackPlantConfig& plant) {
  return DeviceConfig::Of("loopback", plant.dof, plant);
}

}  // namespace teleop::device

TELEOP_REGISTER_DEVICE(loopback, teleop::device::LoopbackBackend())
