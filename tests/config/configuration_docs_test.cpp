// docs/configuration.md documents every key of every registered device backend: a key a backend's reader accepts
// (DeviceBackend::keys) must appear, in backquotes, in the first cell of a table row of that backend's sections
// (the "### `device.<name>...`" headings up to the next "## " heading). An undocumented key fails the suite.

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

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
