#pragma once

#include <Eigen/Core>
#include <string>
#include <string_view>
#include <vector>

#include "teleop/config/key_spec.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/types.hpp"

namespace teleop::config {

/// The key's last path element (what the section's Map holds).
std::string LeafOf(const KeySpec& spec);
/// One line for `--list-devices`: "number, kg, > 0, required: Device mass per DOF. ...".
std::string DescribeKey(const KeySpec& spec);
/// Its docs row: "| `mass_kg` | number, kg | **required** | > 0 | Device mass per DOF. ... |".
std::string KeyTableRow(const KeySpec& spec);
/// Reads a kNumber key from `map`: required (a missing key is an error at the section) or its default, checked
/// against its range with its unit in the message.
double ReadNumber(const Map& map, const KeySpec& spec);
/// Reads a kInteger key: required or its default, in [low, high].
int ReadInteger(const Map& map, const KeySpec& spec);
/// The default as the docs and `--list-devices` print it ("10", "unicycle", "true", "\"\"").
std::string DefaultText(const KeySpec& spec);
/// A kChoice key's words as a message lists them: "warn, lengthen_lookahead or brake".
std::string ChoiceWords(const KeySpec& spec);
/// Reads a kChoice key: the index of its word in `choices` (required or `default_choice`); any other word is an
/// error at the value naming the allowed words ("must be unicycle or bicycle, got 'x'").
int ReadChoice(const Map& map, const KeySpec& spec);
/// ReadChoice as the config enum whose values are the indices of `choices`.
template <typename Enum>
Enum ReadChoiceAs(const Map& map, const KeySpec& spec) {
  return static_cast<Enum>(ReadChoice(map, spec));
}
/// Reads a kBool key: required or `default_bool`.
bool ReadBool(const Map& map, const KeySpec& spec);
/// Reads a kText key: required or `default_text`.
std::string ReadText(const Map& map, const KeySpec& spec);
/// Reads a kPair key: two numbers (or one, for both), each checked against the range; absent: `default_pair`.
Eigen::Vector2d ReadPair(const Map& map, const KeySpec& spec);
/// Reads a kPair key as a direction: not zero, normalised (the default is taken as written).
Eigen::Vector2d ReadDirection(const Map& map, const KeySpec& spec);
/// Whether `spec` is a key directly under `prefix` ("" for the section's own keys, "geometry." for a sub-section's)
/// that a section of type `type` accepts (its `when` is "" or `type`; "*": any type, to read the `type` first).
bool IsKeyUnder(const KeySpec& spec, std::string_view prefix, std::string_view type = "");
/// The leaves of `table`'s keys directly under `prefix` with type `type`: what a reader's Map accepts there, so a
/// key the reader takes is a key of the table.
template <typename Table>
std::vector<std::string> KeysUnder(const Table& table, std::string_view prefix, std::string_view type = "") {
  std::vector<std::string> leaves;
  for (const KeySpec& spec : table) {
    if (IsKeyUnder(spec, prefix, type)) leaves.push_back(LeafOf(spec));
  }
  return leaves;
}
/// The docs section (dotted path) whose table holds `spec`'s row, for the config section `section` ("device.hybrid"):
/// "device.hybrid.geometry" for "geometry.proximal_1_m" (its markers in docs/configuration.md:
/// teleop/config/config_docs.hpp).
std::string DocsSectionOf(const std::string& section, const KeySpec& spec);
/// Its docs/configuration.md heading: "### `device.hybrid.geometry`".
std::string DocsHeadingOf(const std::string& section, const KeySpec& spec);
/// Reads a kDofValue key: `dof` entries, each checked against the range; absent: the default on every DOF.
DofVector ReadDofValue(const Map& map, const KeySpec& spec, int dof);

}  // namespace teleop::config
