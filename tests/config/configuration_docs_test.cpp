// docs/configuration.md documents every key of every registered device backend: a key a backend's reader accepts
// (DeviceBackend::keys) must appear, in backquotes, in the first cell of a table row of that backend's sections
// (the "### `device.<name>...`" headings up to the next "## " heading). An undocumented key fails the suite. The rows
// of the keys in key tables are generated (`cmake --build build --target config-docs`) and checked to be current.

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/config/config_docs.hpp"
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

/// The line number (1-based) and text of the first line where `a` and `b` differ.
std::string FirstDifference(const std::string& a, const std::string& b) {
  std::istringstream in_a(a);
  std::istringstream in_b(b);
  std::string line_a;
  std::string line_b;
  for (int number = 1;; ++number) {
    const bool more_a = static_cast<bool>(std::getline(in_a, line_a));
    const bool more_b = static_cast<bool>(std::getline(in_b, line_b));
    if (!more_a && !more_b) return "none";
    if (!more_a || !more_b || line_a != line_b) {
      return "line " + std::to_string(number) + "\n  in the file:   " + (more_a ? line_a : "(end of file)") +
             "\n  the generator: " + (more_b ? line_b : "(end of file)");
    }
  }
}

// The key tables are the source of their rows: docs/configuration.md is exactly what teleop-config-docs makes of it
// (teleop/config/config_docs.hpp), so a default, range, unit or meaning changed in a table (or a row edited in the
// docs) fails here until the generator has been run. tests/config/key_tables_docs_test.cpp proves the generator on
// small texts.
TEST(ConfigurationDocs, TheKeyTableRowsAreWhatTheGeneratorWrites) {
  const std::string docs = ReadDocs();
  ASSERT_FALSE(docs.empty()) << "cannot read docs/configuration.md";
  const std::vector<config::KeyRowsSection> sections = config::KeyTableDocsSections();
  const config::KeyTablesRewrite rewrite = config::RewriteKeyTables(docs, sections);
  for (const std::string& error : rewrite.errors) ADD_FAILURE() << "docs/configuration.md:" << error;
  EXPECT_TRUE(rewrite.text == docs)
      << "docs/configuration.md is not what the key tables make: run `cmake --build build --target config-docs` "
         "(then review and commit the diff). First difference: "
      << FirstDifference(docs, rewrite.text);
  std::size_t rows = 0;
  for (const config::KeyRowsSection& section : sections) rows += section.rows.size();
  EXPECT_GE(rows, 250u) << "five backends' tables and link.delay_recheck's";
  // The check can fail: a row of the loopback's table with another default is not what the generator writes.
  const std::string row = "| `encoder_resolution_m` | number, m | 0 | ≥ 0 |";
  const auto at = docs.find(row);
  ASSERT_NE(at, std::string::npos);
  std::string stale = docs;
  stale.replace(at, row.size(), "| `encoder_resolution_m` | number, m | 1 | ≥ 0 |");
  EXPECT_NE(config::RewriteKeyTables(stale, sections).text, stale);
  EXPECT_EQ(config::RewriteKeyTables(stale, sections).text, rewrite.text);
  // Each backend's rows are under its sections' markers: the loopback's mass row is in device.loopback's block.
  const auto block = docs.find("<!-- keys:device.loopback begin");
  ASSERT_NE(block, std::string::npos);
  EXPECT_LT(block, docs.find("| `mass_kg` | number, kg | **required** | > 0 | Device mass per DOF.", block));
  EXPECT_LT(docs.find("| `mass_kg` | number, kg | **required** | > 0 | Device mass per DOF.", block),
            docs.find("<!-- keys:device.loopback end -->", block));
  EXPECT_EQ(config::DocsHeadingOf("device.hybrid", config::KeySpec{.key = "geometry.proximal_1_m"}),
            "### `device.hybrid.geometry`");
  EXPECT_EQ(config::DocsSectionOf("device.hybrid", config::KeySpec{.key = "rig"}), "device.hybrid");
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
