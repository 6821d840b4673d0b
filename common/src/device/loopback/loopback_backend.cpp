// The `loopback` backend: the simulated plant of Abbott & Okamura §4.1 (docs/configuration.md, `device.loopback`).

#include <yaml-cpp/yaml.h>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "loopback_keys.hpp"
#include "teleop/config/key_table.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/backend_key_table.hpp"
#include "teleop/device/loopback.hpp"

namespace teleop::device {
namespace {

using config::Field;
using config::Finite;
using config::IntInRange;
using config::Map;
using config::NonNegative;
using config::Positive;

OperatorSegment ReadSegment(const Field& f, int dof) {
  using Kind = OperatorSegment::Kind;
  // The allowed keys depend on the type: a key of another segment type is rejected.
  const Field type_field = config::TypeOf(
      f, {"type", "axis", "start_s", "duration_s", "from_N", "to_N", "amplitude_N", "frequency_hz", "offset_N"});
  const std::string type = type_field.AsString();
  OperatorSegment s;
  std::optional<Map> map;
  if (type == "hold") {
    s.kind = Kind::kHold;
    map.emplace(f, std::initializer_list<std::string_view>{"type", "axis", "start_s", "duration_s"});
  } else if (type == "step") {
    s.kind = Kind::kStep;
    map.emplace(f, std::initializer_list<std::string_view>{"type", "axis", "start_s", "duration_s", "to_N"});
  } else if (type == "ramp") {
    s.kind = Kind::kRamp;
    map.emplace(f, std::initializer_list<std::string_view>{"type", "axis", "start_s", "duration_s", "from_N", "to_N"});
  } else if (type == "sine") {
    s.kind = Kind::kSine;
    map.emplace(f, std::initializer_list<std::string_view>{"type", "axis", "start_s", "duration_s", "amplitude_N",
                                                           "frequency_hz", "offset_N"});
  } else {
    type_field.Fail("must be one of hold, step, ramp, sine; got '" + type + "'");
  }
  if (auto v = map->Optional("axis")) s.axis = IntInRange(*v, 0, dof - 1);
  s.start_s = NonNegative(map->Required("start_s"), "s");
  if (s.kind == Kind::kRamp) {
    s.duration_s = Positive(map->Required("duration_s"), "s (a ramp needs time; follow it with a hold)");
    s.from_N = Finite(map->Required("from_N"));
    s.to_N = Finite(map->Required("to_N"));
  } else {
    if (auto v = map->Optional("duration_s")) s.duration_s = NonNegative(*v, "s (0 = until the end of the run)");
  }
  if (s.kind == Kind::kStep) s.to_N = Finite(map->Required("to_N"));
  if (s.kind == Kind::kSine) {
    s.amplitude_N = Finite(map->Required("amplitude_N"));
    s.frequency_hz = Positive(map->Required("frequency_hz"), "Hz");
    if (auto v = map->Optional("offset_N")) s.offset_N = Finite(*v);
  }
  return s;
}

void ReadOperator(const Field& f, int dof, SimulatedOperatorConfig& human) {
  std::vector<std::string> keys = config::KeysUnder(loopback_keys::All(), "operator.");
  keys.emplace_back("script");  // a list of typed segments (ReadSegment), a hand `keys` entry, not a table row
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
      {"operator.script", "list of at most 16 segments of F_h*(t)"},
      {"operator.script[].type", "hold, step, ramp or sine"},
      {"operator.script[].axis", "the DOF the segment drives, 0..dof-1; default 0"},
      {"operator.script[].start_s", "segment start (s), >= 0"},
      {"operator.script[].duration_s", "segment length (s); 0 = open-ended (not for a ramp)"},
      {"operator.script[].from_N", "ramp start level (N)"},
      {"operator.script[].to_N", "step level or ramp end level (N)"},
      {"operator.script[].amplitude_N", "sine amplitude (N)"},
      {"operator.script[].frequency_hz", "sine frequency (Hz), > 0"},
      {"operator.script[].offset_N", "sine offset (N); default 0"},
  };
  AdoptKeyTable(b, loopback_keys::All());  // every key but operator.script, written once (loopback_keys.hpp)
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
