// docs/configuration.md documents every key of every registered device backend: a key a backend's reader accepts
// (DeviceBackend::keys) must appear, in backquotes, in the first cell of a table row of that backend's sections
// (the "### `device.<name>...`" headings up to the next "## " heading). An undocumented key fails the suite.

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/config/delay_recheck_keys.hpp"
#include "teleop/config/key_table.hpp"
#include "teleop/device/device_registry.hpp"

namespace teleop {
namespace {

std::string ReadDocs() {
  std::ifstream in(std::string(TELEOP_SOURCE_DIR) + "/docs/configuration.md");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// The first cells of the table rows under the "### `device.<name>" headings.
std::vector<std::string> DocumentedCells(const std::string& docs, const std::string& name) {
  std::vector<std::string> cells;
  std::istringstream lines(docs);
  bool inside = false;
  const std::string heading = "### `device." + name;
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("## ", 0) == 0) inside = false;
    if (line.rfind("### ", 0) == 0) {
      inside = line.rfind(heading, 0) == 0 &&
               (line.size() == heading.size() || line[heading.size()] == '`' || line[heading.size()] == '.');
    }
    if (!inside || line.rfind("| ", 0) != 0) continue;
    const auto end = line.find('|', 1);
    if (end != std::string::npos) cells.push_back(line.substr(1, end - 1));
  }
  return cells;
}

std::string Leaf(const std::string& key) {
  const auto dot = key.rfind('.');
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

TEST(ConfigurationDocs, EveryKeyOfEveryRegisteredBackendIsDocumented) {
  const std::string docs = ReadDocs();
  ASSERT_FALSE(docs.empty()) << "cannot read docs/configuration.md";
  const std::vector<std::string> names = device::RegisteredDevices();
  ASSERT_FALSE(names.empty());
  for (const std::string& name : names) {
    const device::DeviceBackend* backend = device::FindDevice(name);
    ASSERT_NE(backend, nullptr);
    EXPECT_FALSE(backend->keys.empty()) << "backend '" << name << "' lists no config keys";
    const std::vector<std::string> cells = DocumentedCells(docs, name);
    EXPECT_FALSE(cells.empty()) << "docs/configuration.md has no '### `device." << name << "`' section with a table";
    for (const device::ConfigKey& key : backend->keys) {
      const std::string needle = "`" + Leaf(key.key) + "`";
      bool found = false;
      for (const std::string& cell : cells) found = found || cell.find(needle) != std::string::npos;
      EXPECT_TRUE(found) << "device." << name << "." << key.key << " (" << key.description
                         << ") is not documented in docs/configuration.md under '### `device." << name << "...`'";
      EXPECT_FALSE(key.description.empty()) << "device." << name << "." << key.key << " has no description";
    }
  }
}

/// The text under `heading` (a whole line) up to the next heading; "" when docs/configuration.md has no such heading.
std::string SectionText(const std::string& docs, const std::string& heading) {
  const auto at = docs.find("\n" + heading + "\n");
  if (at == std::string::npos) return "";
  const auto body = at + heading.size() + 1;
  const auto next = docs.find("\n#", body);
  return docs.substr(body, next == std::string::npos ? std::string::npos : next + 1 - body);
}

// A backend's key table is the source of its docs rows: each row is in docs/configuration.md verbatim, under the
// heading of its section (config::DocsHeadingOf: "### `device.hybrid.geometry`" for geometry.proximal_1_m), so a
// default, range or unit changed in the table and not in the docs (or the other way round) fails here, and the
// failure prints the heading and the row to paste under it (a new backend: one "### `device.<name>`" heading per
// section of its table, then the rows this test prints).
TEST(ConfigurationDocs, EveryKeyTableRowIsInTheDocsVerbatimUnderItsSection) {
  const std::string docs = ReadDocs();
  int rows = 0;
  for (const std::string& name : device::RegisteredDevices()) {
    for (const config::KeySpec& spec : device::FindDevice(name)->key_table) {
      const std::string heading = config::DocsHeadingOf("device." + name, spec);
      const std::string row = config::KeyTableRow(spec);
      const std::string section = SectionText(docs, heading);
      EXPECT_NE(section.find("\n" + row + "\n"), std::string::npos)
          << "device." << name << "." << spec.key << ": docs/configuration.md lacks, under the heading\n"
          << heading << "\nthe row (into the table: | key | type, unit | default | range | meaning |)\n"
          << row;
      ++rows;
    }
  }
  EXPECT_GE(rows, 7) << "the loopback backend's table (loopback_keys.hpp) has 7 keys";
  config::KeySpec changed{"mass_kg", config::KeyType::kNumber, "kg", config::KeyRange::kPositive, false, 0.05, "x"};
  EXPECT_EQ(docs.find(config::KeyTableRow(changed)), std::string::npos) << "the check can fail";
  EXPECT_EQ(config::KeyTableRow(changed), "| `mass_kg` | number, kg | 0.05 | > 0 | x |");
  // A row under another section's heading is not found: a loopback row is not the hybrid's.
  const config::KeySpec mass{"mass_kg",
                             config::KeyType::kNumber,
                             "kg",
                             config::KeyRange::kPositive,
                             true,
                             0.0,
                             "Device mass per DOF. Paper §4.1: master 0.040, slave 0.036."};
  EXPECT_NE(SectionText(docs, "### `device.loopback`").find(config::KeyTableRow(mass)), std::string::npos);
  EXPECT_EQ(SectionText(docs, "### `device.hybrid`").find(config::KeyTableRow(mass)), std::string::npos);
  EXPECT_EQ(config::DocsHeadingOf("device.hybrid", config::KeySpec{.key = "geometry.proximal_1_m"}),
            "### `device.hybrid.geometry`");
  EXPECT_EQ(config::DocsHeadingOf("device.hybrid", config::KeySpec{.key = "rig"}), "### `device.hybrid`");
}

// The link.delay_recheck key table (teleop/config/delay_recheck_keys.hpp) is the source of its docs rows.
TEST(ConfigurationDocs, TheDelayRecheckRowsAreInTheDocsVerbatim) {
  const std::string docs = ReadDocs();
  const auto section = docs.find("### `link.delay_recheck`");
  ASSERT_NE(section, std::string::npos) << "docs/configuration.md has no link.delay_recheck section";
  for (const config::KeySpec* spec : config::delay_recheck_keys::kAll) {
    const std::string row = config::KeyTableRow(*spec);
    EXPECT_NE(docs.find("\n" + row + "\n", section), std::string::npos)
        << "link.delay_recheck." << spec->key << ": docs/configuration.md lacks the row\n"
        << row;
  }
}

TEST(ConfigurationDocs, TheCheckFindsAMissingKey) {
  // The check itself can fail: a key no section documents is not found.
  const std::vector<std::string> cells = DocumentedCells(ReadDocs(), "loopback");
  bool found = false;
  for (const std::string& cell : cells) found = found || cell.find("`warp_factor`") != std::string::npos;
  EXPECT_FALSE(found);
  bool mass = false;
  for (const std::string& cell : cells) mass = mass || cell.find("`mass_kg`") != std::string::npos;
  EXPECT_TRUE(mass);
}

}  // namespace
}  // namespace teleop
