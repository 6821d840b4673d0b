#include "teleop/config/yaml_reader.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>

#include "teleop/error.hpp"

namespace teleop::config {

namespace {

std::string Describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "nothing (null)";
    case YAML::NodeType::Scalar:
      return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a mapping";
    case YAML::NodeType::Undefined:
      break;
  }
  return "an undefined value";
}

YAML::Mark MarkOf(const YAML::Node& node) noexcept {
  try {
    return node.Mark();
  } catch (...) {
    return YAML::Mark::null_mark();
  }
}

}  // namespace

std::string Located(const std::string& file, const YAML::Mark& mark, const std::string& path,
                    const std::string& reason) {
  std::string out = file;
  if (!mark.is_null()) out += ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1);
  out += ": ";
  if (!path.empty()) out += "key '" + path + "': ";
  return out + reason;
}

void Field::Fail(const std::string& reason) const { throw Error(Located(*file_, MarkOf(node_), path_, reason)); }

double Field::AsDouble() const {
  double value = 0.0;
  if (!node_.IsScalar() || !YAML::convert<double>::decode(node_, value)) {
    Fail("expected a number, got " + Describe(node_));
  }
  return value;
}

int Field::AsInt() const {
  int value = 0;
  if (!node_.IsScalar() || !YAML::convert<int>::decode(node_, value)) {
    Fail("expected an integer, got " + Describe(node_));
  }
  return value;
}

bool Field::AsBool() const {
  bool value = false;
  if (!node_.IsScalar() || !YAML::convert<bool>::decode(node_, value)) {
    Fail("expected true or false, got " + Describe(node_));
  }
  return value;
}

std::string Field::AsString() const {
  if (!node_.IsScalar()) Fail("expected a text value, got " + Describe(node_));
  return node_.Scalar();
}

std::vector<Field> Field::AsList() const {
  if (!node_.IsSequence()) Fail("expected a list, got " + Describe(node_));
  std::vector<Field> out;
  out.reserve(node_.size());
  for (std::size_t i = 0; i < node_.size(); ++i) {
    out.emplace_back(node_[i], path_ + "[" + std::to_string(i) + "]", file_);
  }
  return out;
}

Map::Map(const Field& field, std::initializer_list<std::string_view> allowed)
    : Map(field, std::vector<std::string>(allowed.begin(), allowed.end())) {}

Map::Map(const Field& field, const std::vector<std::string>& allowed) : self_(field) {
  const YAML::Node& node = field.node();
  const auto all_keys = [&allowed] {
    std::string keys;
    for (const std::string& k : allowed) keys += (keys.empty() ? "" : ", ") + k;
    return keys;
  };
  if (!node.IsMap()) field.Fail("expected a mapping (with keys among: " + all_keys() + "), got " + Describe(node));
  for (YAML::const_iterator it = node.begin(); it != node.end(); ++it) {
    // Copies: the iterator hands out a temporary pair.
    const YAML::Node key_node = it->first;
    const YAML::Node value_node = it->second;
    if (!key_node.IsScalar()) {
      throw Error(Located(field.file(), MarkOf(key_node), field.path(), "keys must be plain names"));
    }
    const std::string& key = key_node.Scalar();
    const std::string path = PathOf(key);
    if (Find(key) != nullptr) {
      throw Error(Located(field.file(), MarkOf(key_node), path, "duplicate key (it is already set above)"));
    }
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      std::string reason = "unknown key";
      const std::string best = ClosestMatch(key, allowed);
      if (!best.empty()) reason += " (did you mean '" + best + "'?)";
      reason += "; allowed here: " + all_keys();
      throw Error(Located(field.file(), MarkOf(key_node), path, reason));
    }
    entries_.push_back({key, value_node});
  }
}

const Map::Entry* Map::Find(std::string_view key) const noexcept {
  for (const Entry& e : entries_) {
    if (e.key == key) return &e;
  }
  return nullptr;
}

std::string Map::PathOf(std::string_view key) const {
  return self_.path().empty() ? std::string(key) : self_.path() + "." + std::string(key);
}

Field Map::Required(std::string_view key) const {
  const Entry* e = Find(key);
  if (e == nullptr) {
    throw Error(Located(
        self_.file(), MarkOf(self_.node()), PathOf(key),
        "missing required key" + (self_.path().empty() ? std::string() : " in the '" + self_.path() + "' section")));
  }
  return Field(e->value, PathOf(key), &self_.file());
}

std::optional<Field> Map::Optional(std::string_view key) const {
  const Entry* e = Find(key);
  if (e == nullptr) return std::nullopt;
  return Field(e->value, PathOf(key), &self_.file());
}

std::string BesideConfigFile(const std::string& config_file, const std::string& path) {
  const std::filesystem::path p(path);
  if (p.empty() || !p.is_relative() || config_file.empty()) return path;
  return (std::filesystem::path(config_file).parent_path() / p).string();
}

// ---- value checks -----------------------------------------------------------------------------------------------

std::string Num(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

double Finite(const Field& f) {
  const double v = f.AsDouble();
  if (!std::isfinite(v)) f.Fail("must be a finite number, got " + Num(v));
  return v;
}

double NonNegative(const Field& f, const char* unit) {
  const double v = Finite(f);
  if (v < 0.0) f.Fail("must be >= 0 " + std::string(unit) + ", got " + Num(v));
  return v;
}

double Positive(const Field& f, const char* unit) {
  const double v = Finite(f);
  if (!(v > 0.0)) f.Fail("must be > 0 " + std::string(unit) + ", got " + Num(v));
  return v;
}

double InRange(const Field& f, double low, double high, const char* unit) {
  const double v = Finite(f);
  if (v < low || v > high) f.Fail("must be in " + Num(low) + ".." + Num(high) + " " + unit + ", got " + Num(v));
  return v;
}

int IntInRange(const Field& f, int low, int high) {
  const int v = f.AsInt();
  if (v < low || v > high) {
    f.Fail("must be an integer in " + std::to_string(low) + ".." + std::to_string(high) + ", got " + std::to_string(v));
  }
  return v;
}

DofVector ReadDofVector(const Field& f, int dof, const std::function<double(const Field&)>& check) {
  DofVector out = ZeroDof(dof);
  if (f.IsSequence()) {
    const std::vector<Field> items = f.AsList();
    if (static_cast<int>(items.size()) != dof) {
      f.Fail("expected one number (applied to every DOF) or a list of exactly " + std::to_string(dof) +
             " numbers (dof), got a list of " + std::to_string(items.size()));
    }
    for (int i = 0; i < dof; ++i) out[i] = check(items[static_cast<std::size_t>(i)]);
  } else {
    if (!f.IsScalar()) f.Fail("expected one number or a list of " + std::to_string(dof) + " numbers");
    out.setConstant(check(f));
  }
  return out;
}

DofVector ReadGain(const Map& map, std::string_view key, int dof, bool required, const char* unit) {
  const auto check = [unit](const Field& e) { return NonNegative(e, unit); };
  if (required) return ReadDofVector(map.Required(key), dof, check);
  const auto field = map.Optional(key);
  return field ? ReadDofVector(*field, dof, check) : ZeroDof(dof);
}

Field TypeOf(const Field& f, std::initializer_list<std::string_view> all_keys) {
  if (f.node().IsMap()) {
    const YAML::Node type = f.node()["type"];  // const access: a missing key gives an undefined node
    if (type.IsDefined() && type.IsScalar()) {
      return Field(type, f.path().empty() ? "type" : f.path() + ".type", &f.file());
    }
  }
  return Map(f, all_keys).Required("type");
}

}  // namespace teleop::config
