#pragma once

// One config key written once (no YAML here: device_registry.hpp lists a backend's table). Reading, describing and
// the docs row: teleop/config/key_table.hpp.

#include <array>
#include <cstdint>

namespace teleop::config {

/// What a key holds.
enum class KeyType : std::uint8_t {
  kNumber,    ///< One number.
  kDofValue,  ///< One number for every DOF, or a list of exactly `dof` numbers (ReadDofVector).
  kInteger,   ///< A whole number in [low, high] (range kInRange).
  kText,      ///< A word or path (ReadText); default `default_text`.
  kChoice,    ///< One of the words in `choices` (ReadChoice returns its index); default `choices[default_choice]`.
  kBool,      ///< true or false (ReadBool); default `default_bool`.
  kPair,      ///< Two numbers [a, b] (ReadPair, ReadDirection), each checked against the range; default `default_pair`.
  kSection,   ///< A mapping whose keys are the table's "<key>.*" entries (KeysUnder); it has no value of its own.
};

/// The range a key's value must lie in (the reader's check and the docs' "range" column).
enum class KeyRange : std::uint8_t { kFinite, kPositive, kNonNegative, kInRange /* [low, high] */ };

/// One key of a config section, written once: its reader (ReadNumber, ReadDofValue), its line in `--list-devices`
/// (DescribeKey) and its row in docs/configuration.md (KeyTableRow, written between the section's markers by
/// `cmake --build build --target config-docs`, teleop/config/config_docs.hpp) all come from it. A backend keeps its
/// table in one private header (common/src/device/<name>/<name>_keys.hpp), takes an optional key's default from its
/// config struct's member initialiser, and lists the table with device::AdoptKeyTable
/// (teleop/device/backend_key_table.hpp).
struct KeySpec {
  const char* key = "";  ///< Path below the section, e.g. "mass_kg", "operator.mass_kg" (the reader reads the leaf).
  KeyType type = KeyType::kNumber;
  const char* unit = "";  ///< SI unit as the docs write it ("kg", "N·s/m"); "" for a pure number.
  KeyRange range = KeyRange::kFinite;
  bool required = false;
  double default_value = 0.0;  ///< When not required and absent.
  const char* meaning = "";    ///< One sentence for the docs and `--list-devices`.
  double low = 0.0;            ///< kInRange: the smallest value allowed.
  double high = 0.0;           ///< kInRange: the largest value allowed.
  /// kChoice: the allowed words, in the order of the config enum they name (unused entries nullptr).
  std::array<const char*, 4> choices{};
  int default_choice = 0;                ///< kChoice: the index of the default word in `choices`.
  bool default_bool = false;             ///< kBool: the default.
  const char* default_text = "";         ///< kText: the default.
  std::array<double, 2> default_pair{};  ///< kPair: the default.
  /// A key of a typed section (one with a `type` choice): the type word it belongs to ("" = every type). The reader
  /// accepts it only with that type (KeysUnder), and its docs row and `--list-devices` line say so.
  const char* when = "";
};

}  // namespace teleop::config
