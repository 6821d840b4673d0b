#include "teleop/config/key_table.hpp"

namespace teleop::config {

namespace {

std::string RangeText(const KeySpec& spec) {
  switch (spec.range) {
    case KeyRange::kFinite:
      return "finite";
    case KeyRange::kPositive:
      return "> 0";
    case KeyRange::kNonNegative:
      return "≥ 0";
    case KeyRange::kInRange:
      return Num(spec.low) + ".." + Num(spec.high);
  }
  return "";
}

std::string TypeText(const KeySpec& spec) {
  std::string text = spec.type == KeyType::kDofValue  ? "DOF value"
                     : spec.type == KeyType::kInteger ? "integer"
                                                      : "number";
  if (spec.unit[0] != '\0') text += std::string(", ") + spec.unit;
  return text;
}

double Checked(const Field& f, const KeySpec& spec) {
  switch (spec.range) {
    case KeyRange::kPositive:
      return Positive(f, spec.unit);
    case KeyRange::kNonNegative:
      return NonNegative(f, spec.unit);
    case KeyRange::kInRange:
      return InRange(f, spec.low, spec.high, spec.unit);
    case KeyRange::kFinite:
      break;
  }
  return Finite(f);
}

}  // namespace

std::string LeafOf(const KeySpec& spec) {
  const std::string key = spec.key;
  const auto dot = key.rfind('.');
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

std::string DescribeKey(const KeySpec& spec) {
  return TypeText(spec) + ", " + RangeText(spec) + ", " +
         (spec.required ? std::string("required") : "default " + Num(spec.default_value)) + ": " + spec.meaning;
}

std::string KeyTableRow(const KeySpec& spec) {
  return "| `" + LeafOf(spec) + "` | " + TypeText(spec) + " | " +
         (spec.required ? std::string("**required**") : Num(spec.default_value)) + " | " + RangeText(spec) + " | " +
         spec.meaning + " |";
}

double ReadNumber(const Map& map, const KeySpec& spec) {
  const std::string leaf = LeafOf(spec);
  if (spec.required) return Checked(map.Required(leaf), spec);
  if (auto v = map.Optional(leaf)) return Checked(*v, spec);
  return spec.default_value;
}

int ReadInteger(const Map& map, const KeySpec& spec) {
  const std::string leaf = LeafOf(spec);
  const auto check = [&spec](const Field& f) {
    return IntInRange(f, static_cast<int>(spec.low), static_cast<int>(spec.high));
  };
  if (spec.required) return check(map.Required(leaf));
  if (auto v = map.Optional(leaf)) return check(*v);
  return static_cast<int>(spec.default_value);
}

DofVector ReadDofValue(const Map& map, const KeySpec& spec, int dof) {
  const std::string leaf = LeafOf(spec);
  const auto check = [&spec](const Field& f) { return Checked(f, spec); };
  if (spec.required) return ReadDofVector(map.Required(leaf), dof, check);
  if (auto v = map.Optional(leaf)) return ReadDofVector(*v, dof, check);
  return DofVector::Constant(dof, spec.default_value);
}

}  // namespace teleop::config
