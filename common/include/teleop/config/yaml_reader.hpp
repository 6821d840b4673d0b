#pragma once

// Typed, strict access to a YAML document that reports every problem as "FILE:LINE:COLUMN: key 'a.b[2].c': reason"
// (teleop::Error). The process config reader and every device backend's section reader use it (library
// teleop::config_reader), so a backend's errors look like the rest of the config's.

#include <yaml-cpp/yaml.h>

#include <functional>
#include <initializer_list>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "teleop/closest_match.hpp"
#include "teleop/types.hpp"

namespace teleop::config {

/// One value in the document: its node, its dotted key path and the file it came from.
class Field {
 public:
  Field(const YAML::Node& node, std::string path, const std::string* file)
      : node_(node), path_(std::move(path)), file_(file) {}

  const YAML::Node& node() const noexcept { return node_; }
  const std::string& path() const noexcept { return path_; }
  const std::string& file() const noexcept { return *file_; }

  /// Throws teleop::Error located at this value.
  [[noreturn]] void Fail(const std::string& reason) const;

  double AsDouble() const;  ///< Any number; NaN and infinities are returned as such (range checks reject them).
  int AsInt() const;
  bool AsBool() const;
  std::string AsString() const;
  bool IsSequence() const { return node_.IsSequence(); }
  bool IsScalar() const { return node_.IsScalar(); }
  /// The elements of a sequence, paths "path[i]"; throws when this is not a sequence.
  std::vector<Field> AsList() const;

 private:
  YAML::Node node_;
  std::string path_;
  const std::string* file_;
};

/// A mapping whose keys are checked against a closed list: unknown keys (with a "did you mean" hint), duplicate
/// keys and non-scalar keys are errors at the offending key.
class Map {
 public:
  /// Checks every key of `field` against `allowed`. Throws when `field` is not a mapping or a key is wrong.
  Map(const Field& field, std::initializer_list<std::string_view> allowed);
  /// Same, with a list built at run time (the device section, whose keys are the registered backends).
  Map(const Field& field, const std::vector<std::string>& allowed);

  bool Has(std::string_view key) const noexcept { return Find(key) != nullptr; }
  /// The value under `key`; a missing key is an error located at this mapping.
  Field Required(std::string_view key) const;
  std::optional<Field> Optional(std::string_view key) const;
  const Field& self() const noexcept { return self_; }
  std::string PathOf(std::string_view key) const;

 private:
  struct Entry {
    std::string key;
    YAML::Node value;
  };
  const Entry* Find(std::string_view key) const noexcept;

  Field self_;
  std::vector<Entry> entries_;
};

/// "FILE:LINE:COL: key 'path': reason" (1-based line and column).
std::string Located(const std::string& file, const YAML::Mark& mark, const std::string& path,
                    const std::string& reason);

/// The closest of `candidates` to `word` when it is a plausible typo (teleop/closest_match.hpp).
using teleop::ClosestMatch;

/// A file a config names, as the config means it: a relative `path` is beside `config_file` (the file the key was
/// read from: Field::file()); an absolute one, an empty one, or any path when the config was not read from a file
/// (config_file empty) is returned as it is. link.security.key_file, stability.human_bounds, drives[].eds.
std::string BesideConfigFile(const std::string& config_file, const std::string& path);

// ---- value checks shared by every section reader: each throws at the value with its unit in the message ----------

/// `value` as text the way messages print numbers.
/// One degree in radians: a `..._deg` key's value times kDeg is what the config structs hold (rad).
inline constexpr double kDeg = std::numbers::pi / 180.0;

std::string Num(double value);
double Finite(const Field& f);
double NonNegative(const Field& f, const char* unit);
double Positive(const Field& f, const char* unit);
/// In [low, high].
double InRange(const Field& f, double low, double high, const char* unit);
int IntInRange(const Field& f, int low, int high);
/// A per-DOF quantity: one number for every DOF, or a list of exactly `dof` numbers. `check` validates one entry.
DofVector ReadDofVector(const Field& f, int dof, const std::function<double(const Field&)>& check);
/// A per-DOF gain (≥ 0, `unit`); an absent optional key gives zeros.
DofVector ReadGain(const Map& map, std::string_view key, int dof, bool required, const char* unit);
/// The `type` of a typed mapping (a script segment, an environment), read before the keys are checked so that the
/// allowed keys can depend on it. `all_keys` is the union, used when `type` itself is missing or not text.
Field TypeOf(const Field& f, std::initializer_list<std::string_view> all_keys);

/// The names the reader had before it became public.
namespace detail {
using config::Field;
using config::Located;
using config::Map;
}  // namespace detail

}  // namespace teleop::config
