// The backends' key tables (teleop/config/key_spec.hpp): every key a table lists is in `--list-devices` with the line
// the table writes, a reader refuses a key it does not know by its name, and the table's reading of a value and of
// its absence is what the backend's reader does.

#include "teleop/config/key_table.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/can_port_yaml.hpp"
#include "teleop/node/device_list.hpp"

namespace teleop {
namespace {

/// A section a backend accepts, with the process's role and dof in `context`.
struct Minimal {
  std::string yaml;  ///< One flow mapping on one line (a test puts a key in front of the first).
  device::SectionContext context;
};

/// `node` as flow YAML on one line (a node read from block YAML keeps its block style when emitted).
std::string FlowText(const YAML::Node& node) {
  YAML::Node flow = YAML::Clone(node);
  std::vector<YAML::Node> pending{flow};
  while (!pending.empty()) {
    YAML::Node n = pending.back();
    pending.pop_back();
    if (!n.IsMap() && !n.IsSequence()) continue;
    n.SetStyle(YAML::EmitterStyle::Flow);
    for (auto it = n.begin(); it != n.end(); ++it) pending.push_back(n.IsMap() ? it->second : *it);
  }
  YAML::Emitter out;
  out << flow;
  return out.c_str();
}

/// Each backend's section from the rig configs every backend brings (deploy/configs/**/*.yaml, the first in path
/// order whose device.backend names it): a new backend needs no entry here.
const std::map<std::string, Minimal>& MinimalSections() {
  static const std::map<std::string, Minimal> sections = [] {
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(TELEOP_SOURCE_DIR "/deploy/configs")) {
      if (entry.path().extension() == ".yaml") files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    std::map<std::string, Minimal> found;
    for (const std::filesystem::path& file : files) {
      const YAML::Node config = YAML::LoadFile(file.string());
      const YAML::Node device = config["device"];
      if (!config["role"] || !device || !device["backend"]) continue;
      const std::string backend = device["backend"].as<std::string>();
      if (found.count(backend) != 0) continue;
      const YAML::Node section = device[backend] ? device[backend] : YAML::Node(YAML::NodeType::Map);
      const Role role = config["role"].as<std::string>() == "slave" ? Role::kSlave : Role::kMaster;
      found[backend] = {FlowText(section), {role, config["dof"] ? config["dof"].as<int>() : 1}};
    }
    return found;
  }();
  return sections;
}

/// Every rig config's section of every backend (deploy/configs/**/*.yaml in path order), as YAML.
struct RigSection {
  std::string file;
  YAML::Node section;
  device::SectionContext context;
};
const std::map<std::string, std::vector<RigSection>>& RigSections() {
  static const std::map<std::string, std::vector<RigSection>> sections = [] {
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(TELEOP_SOURCE_DIR "/deploy/configs")) {
      if (entry.path().extension() == ".yaml") files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    std::map<std::string, std::vector<RigSection>> found;
    for (const std::filesystem::path& file : files) {
      const YAML::Node config = YAML::LoadFile(file.string());
      const YAML::Node device = config["device"];
      if (!config["role"] || !device || !device["backend"]) continue;
      const std::string backend = device["backend"].as<std::string>();
      const YAML::Node section = device[backend] ? device[backend] : YAML::Node(YAML::NodeType::Map);
      const Role role = config["role"].as<std::string>() == "slave" ? Role::kSlave : Role::kMaster;
      found[backend].push_back(
          {file.string(), YAML::Clone(section), {role, config["dof"] ? config["dof"].as<int>() : 1}});
    }
    return found;
  }();
  return sections;
}

std::string ReadError(const std::string& backend, const std::string& yaml, const device::SectionContext& context) {
  static const std::string file = "keys.yaml";
  const YAML::Node node = YAML::Load(yaml);
  const config::Field field(node, "device." + backend, &file);
  try {
    (void)device::FindDevice(backend)->read(&field, context);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(KeyTable, ListDevicesShowsEveryKeyOfEveryBackendsTable) {
  const std::string listing = node::DescribeDevices();
  int tables = 0;
  for (const std::string& name : device::RegisteredDevices()) {
    const device::DeviceBackend* backend = device::FindDevice(name);
    if (backend->key_table.empty()) continue;
    ++tables;
    EXPECT_EQ(MinimalSections().count(name), 1u)
        << name << ": no rig config in deploy/configs/ uses it, so the unknown-key and range checks cannot read it";
    const auto section = listing.find("\n" + name + ": ");
    ASSERT_NE(section, std::string::npos) << name;
    const auto next = listing.find("\n\n", section + 1);
    const std::string own = listing.substr(section, next == std::string::npos ? std::string::npos : next + 1 - section);
    for (const config::KeySpec& spec : backend->key_table) {
      const std::string line = "\n    " + std::string(spec.key) + ": " + config::DescribeKey(spec) + "\n";
      EXPECT_NE(own.find(line), std::string::npos) << name << ": --list-devices lacks" << line << "in\n" << own;
    }
  }
  EXPECT_GE(tables, 4) << "loopback, admittance, hybrid and cobot each have a key table";
  EXPECT_EQ(listing.find("\n    warp_factor: "), std::string::npos) << "the check can fail";
}

TEST(KeyTable, EveryBackendRefusesAnUnknownKeyByItsName) {
  for (const auto& [name, minimal] : MinimalSections()) {
    ASSERT_NE(device::FindDevice(name), nullptr) << name;
    EXPECT_EQ(ReadError(name, minimal.yaml, minimal.context), "") << name << ": the minimal section is valid";
    std::string yaml = minimal.yaml;
    yaml.insert(1, yaml.size() > 2 ? "warp_factor: 9, " : "warp_factor: 9");
    const std::string error = ReadError(name, yaml, minimal.context);
    EXPECT_NE(error.find("warp_factor"), std::string::npos) << name << ": " << error;
    EXPECT_NE(error.find("keys.yaml:1:"), std::string::npos) << name << ": " << error;
  }
}

TEST(KeyTable, AValueOutOfItsTablesRangeIsRefusedWithTheKeysName) {
  // One key of each backend's table, at a value outside its range: the reader's message names the key.
  for (const auto& [name, minimal] : MinimalSections()) {
    for (const config::KeySpec& spec : device::FindDevice(name)->key_table) {
      // A text key takes any word; a choice or boolean one refuses ".nan" as it refuses any word not in its list.
      if (spec.required || spec.type == config::KeyType::kDofValue || spec.type == config::KeyType::kText ||
          spec.type == config::KeyType::kSection) {
        continue;
      }
      const std::string leaf = config::LeafOf(spec);
      if (leaf != spec.key) continue;  // a nested key: its parent has keys of its own
      const char* bad = spec.range == config::KeyRange::kFinite ? ".nan" : "-1e9";
      YAML::Node section = YAML::Load(minimal.yaml);
      section.remove(leaf);  // the rig's own value of it
      std::string yaml = FlowText(section);
      yaml.insert(1, leaf + ": " + bad + (yaml.size() > 2 ? ", " : ""));
      const std::string error = ReadError(name, yaml, minimal.context);
      EXPECT_NE(error.find("'device." + name + "." + leaf + "'"), std::string::npos)
          << name << "." << leaf << " = " << bad << ": " << error;
    }
  }
}

TEST(KeyTable, ReadersAndDescriptionsFollowTheTable) {
  const config::KeySpec ratio{.key = "bandwidth_ratio",
                              .range = config::KeyRange::kInRange,
                              .default_value = 10.0,
                              .meaning = "x",
                              .low = 1.0,
                              .high = 1000.0};
  const config::KeySpec cycles{.key = "cycles",
                               .type = config::KeyType::kInteger,
                               .range = config::KeyRange::kInRange,
                               .default_value = 10.0,
                               .meaning = "y",
                               .low = 1.0,
                               .high = 100.0};
  EXPECT_EQ(config::KeyTableRow(ratio), "| `bandwidth_ratio` | number | 10 | 1..1000 | x |");
  EXPECT_EQ(config::DescribeKey(cycles), "integer, 1..100, default 10: y");
  static const std::string file = "k.yaml";
  const YAML::Node empty = YAML::Load("{}");
  const config::Field empty_field(empty, "s", &file);
  const config::Map none(empty_field, {"bandwidth_ratio", "cycles"});
  EXPECT_EQ(config::ReadNumber(none, ratio), 10.0);
  EXPECT_EQ(config::ReadInteger(none, cycles), 10);
  const YAML::Node given = YAML::Load("{bandwidth_ratio: 20, cycles: 7}");
  const config::Field given_field(given, "s", &file);
  const config::Map some(given_field, {"bandwidth_ratio", "cycles"});
  EXPECT_EQ(config::ReadNumber(some, ratio), 20.0);
  EXPECT_EQ(config::ReadInteger(some, cycles), 7);
  const YAML::Node bad = YAML::Load("{bandwidth_ratio: 0.5, cycles: 2.5}");
  const config::Field bad_field(bad, "s", &file);
  const config::Map wrong(bad_field, {"bandwidth_ratio", "cycles"});
  EXPECT_THROW((void)config::ReadNumber(wrong, ratio), Error);
  EXPECT_THROW((void)config::ReadInteger(wrong, cycles), Error);
}

TEST(KeyTable, AChoiceKeyRefusesAWrongWordWithTheWordsItAllows) {
  const config::KeySpec mode{.key = "mode",
                             .type = config::KeyType::kChoice,
                             .meaning = "m",
                             .choices = {"position", "velocity", "torque"},
                             .default_choice = 1};
  const config::KeySpec on{.key = "on", .type = config::KeyType::kBool, .meaning = "b", .default_bool = true};
  const config::KeySpec eds{.key = "eds", .type = config::KeyType::kText, .meaning = "t", .default_text = "a.eds"};
  EXPECT_EQ(config::KeyTableRow(mode), "| `mode` | choice | velocity | position, velocity, torque | m |");
  EXPECT_EQ(config::DescribeKey(on), "boolean, true | false, default true: b");
  EXPECT_EQ(config::DescribeKey(mode), "choice, position | velocity | torque, default velocity: m");
  EXPECT_EQ(config::KeyTableRow(eds), "| `eds` | text | \"a.eds\" | any | t |");
  static const std::string file = "k.yaml";
  const auto map_of = [](const YAML::Node& node) {
    return config::Map(config::Field(node, "s", &file), {"mode", "on", "eds"});
  };
  const YAML::Node empty = YAML::Load("{}");
  EXPECT_EQ(config::ReadChoice(map_of(empty), mode), 1);
  EXPECT_TRUE(config::ReadBool(map_of(empty), on));
  EXPECT_EQ(config::ReadText(map_of(empty), eds), "a.eds");
  const YAML::Node given = YAML::Load("{mode: torque, on: false, eds: b.eds}");
  EXPECT_EQ(config::ReadChoice(map_of(given), mode), 2);
  EXPECT_FALSE(config::ReadBool(map_of(given), on));
  EXPECT_EQ(config::ReadText(map_of(given), eds), "b.eds");
  const YAML::Node wrong = YAML::Load("{mode: current}");
  try {
    (void)config::ReadChoice(map_of(wrong), mode);
    ADD_FAILURE() << "accepted 'current'";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("k.yaml:1:8: key 's.mode': must be position, velocity or torque, got 'current'"),
        std::string::npos)
        << e.what();
  }
}

// The other way round from the unknown-key check: a key the reader accepts is a key of its table. Every key the rig
// configs write at the top of a backend's section, or inside a section whose keys the table lists, is a table key
// (or, for a key not tabled yet — a sub-section, a list — a `keys` entry), and every optional table key set to its
// default in a rig config is read: accepted, or refused by its own name for a reason other than "unknown key".
TEST(KeyTable, EveryKeyTheRigConfigsWriteIsATableKeyAndEveryTableKeyIsRead) {
  int checked = 0;
  for (const auto& [name, sections] : RigSections()) {
    const device::DeviceBackend* backend = device::FindDevice(name);
    ASSERT_NE(backend, nullptr) << name;
    if (backend->key_table.empty()) continue;
    const auto tabled = [&](const std::string& key) {
      for (const config::KeySpec& spec : backend->key_table) {
        if (key == spec.key) return true;
      }
      return false;
    };
    const auto listed = [&](const std::string& key) {
      for (const device::ConfigKey& k : backend->keys) {
        if (key == k.key) return true;
      }
      return false;
    };
    const auto has_children = [&](const std::string& section) {
      for (const config::KeySpec& spec : backend->key_table) {
        if (config::IsKeyUnder(spec, section + ".", "*")) return true;
      }
      return false;
    };
    for (const RigSection& rig : sections) {
      if (!rig.section.IsMap()) continue;
      for (auto it = rig.section.begin(); it != rig.section.end(); ++it) {
        const std::string key = it->first.as<std::string>();
        EXPECT_TRUE(tabled(key) || listed(key)) << rig.file << ": device." << name << "." << key;
        if (!tabled(key) || !has_children(key) || !it->second.IsMap()) continue;
        for (auto inner = it->second.begin(); inner != it->second.end(); ++inner) {
          const std::string path = key + "." + inner->first.as<std::string>();
          EXPECT_TRUE(tabled(path) || listed(path))
              << rig.file << ": device." << name << "." << path << " is neither in the table nor a `keys` entry";
          ++checked;
        }
      }
    }
    for (const config::KeySpec& spec : backend->key_table) {
      if (spec.required || spec.type == config::KeyType::kSection) continue;
      const std::string key = spec.key;
      const auto dot = key.rfind('.');
      const std::string parent = dot == std::string::npos ? "" : key.substr(0, dot);
      if (parent.find('[') != std::string::npos) continue;  // a list's item (admittance drives[])
      bool reached = false;
      std::string error;
      for (const RigSection& rig : sections) {
        YAML::Node section = YAML::Clone(rig.section);
        if (!section.IsMap()) continue;
        YAML::Node holder = parent.empty() ? section : section[parent];
        if (!holder.IsMap()) continue;
        if (spec.when[0] != '\0' && (!holder["type"] || holder["type"].as<std::string>() != spec.when)) continue;
        holder[config::LeafOf(spec)] = YAML::Load(config::DefaultText(spec));
        error = ReadError(name, FlowText(section), rig.context);
        const bool own = error.find("'device." + name + "." + key + "'") != std::string::npos;
        reached = error.empty() || (own && error.find("unknown key") == std::string::npos);
        if (reached) break;
      }
      if (!error.empty() || reached) {
        EXPECT_TRUE(reached) << "device." << name << "." << key << " set to " << config::DefaultText(spec)
                             << " is not read: " << error;
        ++checked;
      }
    }
  }
  EXPECT_GE(checked, 100) << "keys checked";
}

// A typed section read through its table (loopback environment): a key of another type is refused by its name, a
// wrong type word names the words, and the wall's axis is checked against the process's dof.
TEST(KeyTable, ATypedSectionTakesOnlyTheKeysOfItsType) {
  const device::SectionContext one{Role::kSlave, 1};
  const std::string plant = "{mass_kg: 0.036, damping_Ns_per_m: 0.49, environment: ";
  EXPECT_EQ(ReadError("loopback", plant + "{type: free}}", one), "");
  EXPECT_EQ(ReadError("loopback", plant + "{type: wall, position_m: 0.01, stiffness_N_per_m: 500}}", one), "");
  EXPECT_NE(ReadError("loopback", plant + "{type: free, position_m: 0.01}}", one)
                .find("'device.loopback.environment.position_m'"),
            std::string::npos);
  EXPECT_NE(ReadError("loopback", plant + "{type: wal}}", one).find("must be free or wall, got 'wal'"),
            std::string::npos);
  EXPECT_NE(ReadError("loopback", plant + "{type: wall, stiffness_N_per_m: 500}}", one).find("position_m"),
            std::string::npos);
  EXPECT_NE(ReadError("loopback", plant + "{type: wall, axis: 1, position_m: 0, stiffness_N_per_m: 5}}", one)
                .find("must be below dof (1)"),
            std::string::npos);
  EXPECT_EQ(ReadError("loopback", plant + "{type: wall, axis: 1, position_m: 0, stiffness_N_per_m: 5}}",
                      device::SectionContext{Role::kSlave, 2}),
            "");
}

// The one CAN bus section reader the admittance, cobot and hybrid backends share.
TEST(KeyTable, TheSharedCanSectionReaderReadsAndRefuses) {
  static const std::string file = "can.yaml";
  const auto read = [](const std::string& yaml, fieldbus::CanMediumKey medium) {
    const YAML::Node node = YAML::Load(yaml);
    const config::Field field(node, "device.x.can", &file);
    fieldbus::CanPortConfig can;
    fieldbus::ReadCanPortSection(field, can, medium);
    return can;
  };
  const auto error = [&](const std::string& yaml, fieldbus::CanMediumKey medium) -> std::string {
    try {
      (void)read(yaml, medium);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  using fieldbus::CanMediumKey;
  const fieldbus::CanPortConfig socket = read("{interface: vcan0}", CanMediumKey::kOptional);
  EXPECT_EQ(socket.medium, transport::CanMedium::kSocketCan);
  EXPECT_EQ(socket.interface_name, "vcan0");
  const fieldbus::CanPortConfig daemon =
      read("{medium: emulated, bus: \"127.0.0.2:47301\", connect_timeout_ms: 250}", CanMediumKey::kRequired);
  EXPECT_EQ(daemon.medium, transport::CanMedium::kEmulatedBus);
  EXPECT_EQ(daemon.emulated_bus_host, "127.0.0.2");
  EXPECT_EQ(daemon.emulated_bus_port, 47301);
  EXPECT_EQ(daemon.connect_timeout_ms, 250.0);
  EXPECT_NE(error("{interface: vcan0}", CanMediumKey::kRequired).find("'device.x.can.medium'"), std::string::npos);
  EXPECT_NE(error("{medium: ethercat}", CanMediumKey::kOptional).find("socketcan or emulated"), std::string::npos);
  EXPECT_NE(error("{medium: emulated, bus: \"127.0.0.1:70000\"}", CanMediumKey::kOptional).find("HOST:PORT"),
            std::string::npos);
  EXPECT_NE(error("{medium: emulated, interface: can0}", CanMediumKey::kOptional).find("only for medium socketcan"),
            std::string::npos);
  EXPECT_NE(error("{}", CanMediumKey::kOptional).find("interface"), std::string::npos);
  EXPECT_NE(error("{interface: can0, baud: 1}", CanMediumKey::kOptional).find("baud"), std::string::npos);
  EXPECT_NE(error("{interface: can0, connect_timeout_ms: 0}", CanMediumKey::kOptional).find("must be > 0 ms"),
            std::string::npos);
}

}  // namespace
}  // namespace teleop
