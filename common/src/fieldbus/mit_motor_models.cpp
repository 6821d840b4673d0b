#include "teleop/fieldbus/mit_motor_models.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <filesystem>
#include <vector>

#include "teleop/closest_match.hpp"
#include "teleop/config/key_table.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/error.hpp"

// The build defines both (common/src/fieldbus/CMakeLists.txt); other builds of this file (the fuzz harness) get the
// Debian package's path and no source tree.
#ifndef TELEOP_INSTALL_DATADIR
#define TELEOP_INSTALL_DATADIR "/usr/share/teleop/motors"
#endif
#ifndef TELEOP_SOURCE_MODELS
#define TELEOP_SOURCE_MODELS ""
#endif

namespace teleop::fieldbus {

namespace {

using config::KeyRange;
using config::KeySpec;
using config::KeyType;

constexpr KeySpec kPMax{.key = "p_max_rad",
                        .type = KeyType::kNumber,
                        .unit = "rad",
                        .range = KeyRange::kPositive,
                        .required = true,
                        .meaning = "P_MAX: the position field spans -P_MAX..P_MAX (register 21)."};
constexpr KeySpec kVMax{.key = "v_max_rad_per_s",
                        .type = KeyType::kNumber,
                        .unit = "rad/s",
                        .range = KeyRange::kPositive,
                        .required = true,
                        .meaning = "V_MAX: the velocity field spans -V_MAX..V_MAX (register 22)."};
constexpr KeySpec kTMax{.key = "t_max_Nm",
                        .type = KeyType::kNumber,
                        .unit = "N·m",
                        .range = KeyRange::kPositive,
                        .required = true,
                        .meaning = "T_MAX: the torque field spans -T_MAX..T_MAX (register 23)."};
constexpr KeySpec kPeak{.key = "peak_torque_Nm",
                        .type = KeyType::kNumber,
                        .unit = "N·m",
                        .range = KeyRange::kPositive,
                        .required = true,
                        .meaning = "The torque the motor can give; commands are clamped to it."};

}  // namespace

std::map<std::string, MitMotorModel> ReadMitMotorModels(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw Error(fmt::format("{}: cannot read the MIT motor models file: {}", path, e.what()));
  }
  const config::Field top(root, "", &path);
  const config::Map doc(top, {"models"});
  const config::Field models = doc.Required("models");
  if (!models.node().IsMap() || models.node().size() == 0) models.Fail("must map model names to their ranges");
  std::map<std::string, MitMotorModel> out;
  for (const auto& entry : models.node()) {
    const std::string name = entry.first.as<std::string>();
    const config::Map m(config::Field(entry.second, "models." + name, &path),
                        {kPMax.key, kVMax.key, kTMax.key, kPeak.key});
    MitMotorModel model;
    model.ranges.position_max_rad = config::ReadNumber(m, kPMax);
    model.ranges.velocity_max_rad_per_s = config::ReadNumber(m, kVMax);
    model.ranges.torque_max_Nm = config::ReadNumber(m, kTMax);
    model.peak_torque_Nm = config::ReadNumber(m, kPeak);
    if (model.peak_torque_Nm > model.ranges.torque_max_Nm) {
      m.Required(kPeak.key).Fail(fmt::format("{} N·m is beyond the torque range T_MAX {} N·m", model.peak_torque_Nm,
                                             model.ranges.torque_max_Nm));
    }
    out.emplace(name, model);
  }
  return out;
}

const MitMotorModel& FindMitMotorModel(const std::map<std::string, MitMotorModel>& models, const std::string& name,
                                       const std::string& path) {
  const auto it = models.find(name);
  if (it != models.end()) return it->second;
  std::vector<std::string> names;
  names.reserve(models.size());
  for (const auto& [n, _] : models) names.push_back(n);
  const std::string closest = ClosestMatch(name, names);
  throw Error(fmt::format("MIT motor model '{}' is not in {} (it has {}){}", name, path, fmt::join(names, ", "),
                          closest.empty() ? "" : fmt::format("; did you mean '{}'?", closest)));
}

std::string DefaultMitMotorModelsPath() {
  const std::filesystem::path installed = std::filesystem::path(TELEOP_INSTALL_DATADIR) / "mit-models.yaml";
  if (std::filesystem::exists(installed)) return installed.string();
  return std::string(TELEOP_SOURCE_MODELS);
}

}  // namespace teleop::fieldbus
