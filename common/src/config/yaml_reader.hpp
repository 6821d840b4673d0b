#pragma once

// Private to the config library: typed, strict access to a YAML document that reports every problem as
// "FILE:LINE:COLUMN: key 'a.b[2].c': reason" (teleop::Error).

#include <yaml-cpp/yaml.h>

#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace teleop::config::detail {

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

}  // namespace teleop::config::detail
