#include "teleop/config/key_table.hpp"

#include <cmath>
#include <optional>
#include <string>

namespace teleop::config {

namespace {

/// `separator` between a choice's words: ", " in a docs cell, " | " in a `--list-devices` line (whose fields are
/// separated by commas).
std::string RangeText(const KeySpec& spec, const std::string& separator = ", ") {
  switch (spec.type) {
    case KeyType::kChoice: {
      std::string words;
      for (const char* w : spec.choices) {
        if (w == nullptr) break;
        words += (words.empty() ? "" : separator) + std::string(w);
      }
      return words;
    }
    case KeyType::kBool:
      return "true" + separator + "false";
    case KeyType::kText:
      return "any";
    case KeyType::kSection:
      return "";
    default:
      break;
  }
  switch (spec.range) {
    case KeyRange::kFinite:
      return "finite";
    case KeyRange::kPositive:
      return "> 0";
    case KeyRange::kNonNegative:
      return "≥ 0";
    case KeyRange::kInRange:
      if (spec.type == KeyType::kInteger) {  // exact bounds (0..2147483647), not Num's 6 significant digits
        return std::to_string(std::llround(spec.low)) + ".." + std::to_string(std::llround(spec.high));
      }
      return Num(spec.low) + ".." + Num(spec.high);
  }
  return "";
}

std::string TypeText(const KeySpec& spec) {
  std::string text = spec.type == KeyType::kDofValue  ? "DOF value"
                     : spec.type == KeyType::kInteger ? "integer"
                     : spec.type == KeyType::kText    ? "text"
                     : spec.type == KeyType::kChoice  ? "choice"
                     : spec.type == KeyType::kBool    ? "boolean"
                     : spec.type == KeyType::kPair    ? "pair"
                     : spec.type == KeyType::kSection ? "mapping"
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

/// The meaning with the section type the key belongs to, when it belongs to one: "(type wall) Wall stiffness.".
std::string MeaningText(const KeySpec& spec) {
  return spec.when[0] == '\0' ? std::string(spec.meaning) : "(type " + std::string(spec.when) + ") " + spec.meaning;
}

}  // namespace

std::string LeafOf(const KeySpec& spec) {
  const std::string key = spec.key;
  const auto dot = key.rfind('.');
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

std::string DefaultText(const KeySpec& spec) {
  switch (spec.type) {
    case KeyType::kChoice:
      return spec.default_choice >= 0 && spec.default_choice < static_cast<int>(spec.choices.size()) &&
                     spec.choices[spec.default_choice] != nullptr
                 ? spec.choices[spec.default_choice]
                 : "";
    case KeyType::kBool:
      return spec.default_bool ? "true" : "false";
    case KeyType::kText:
      return "\"" + std::string(spec.default_text) + "\"";
    case KeyType::kPair:
      return "[" + Num(spec.default_pair[0]) + ", " + Num(spec.default_pair[1]) + "]";
    case KeyType::kSection:
      return "";
    default:
      return Num(spec.default_value);
  }
}

std::string ChoiceWords(const KeySpec& spec) {
  int n = 0;
  while (n < static_cast<int>(spec.choices.size()) && spec.choices[n] != nullptr) ++n;
  std::string words;
  for (int i = 0; i < n; ++i) {
    if (i > 0) words += i + 1 == n ? " or " : ", ";
    words += spec.choices[i];
  }
  return words;
}

std::string DescribeKey(const KeySpec& spec) {
  if (spec.type == KeyType::kSection) {
    return TypeText(spec) + (spec.required ? ", required" : "") + ": " + MeaningText(spec);
  }
  return TypeText(spec) + ", " + RangeText(spec, " | ") + ", " +
         (spec.required ? std::string("required") : "default " + DefaultText(spec)) + ": " + MeaningText(spec);
}

std::string KeyTableRow(const KeySpec& spec) {
  return "| `" + LeafOf(spec) + "` | " + TypeText(spec) + " | " +
         (spec.required ? std::string("**required**") : DefaultText(spec)) + " | " + RangeText(spec) + " | " +
         MeaningText(spec) + " |";
}

bool IsKeyUnder(const KeySpec& spec, std::string_view prefix, std::string_view type) {
  const std::string_view key = spec.key;
  if (key.substr(0, prefix.size()) != prefix) return false;
  if (key.find('.', prefix.size()) != std::string_view::npos) return false;
  return spec.when[0] == '\0' || type == "*" || type == spec.when;
}

std::string DocsSectionOf(const std::string& section, const KeySpec& spec) {
  const std::string key = spec.key;
  const auto dot = key.rfind('.');
  return section + (dot == std::string::npos ? "" : "." + key.substr(0, dot));
}

std::string DocsHeadingOf(const std::string& section, const KeySpec& spec) {
  return "### `" + DocsSectionOf(section, spec) + "`";
}

int ReadChoice(const Map& map, const KeySpec& spec) {
  const std::string leaf = LeafOf(spec);
  std::optional<Field> v = spec.required ? std::optional<Field>(map.Required(leaf)) : map.Optional(leaf);
  if (!v) return spec.default_choice;
  const std::string word = v->AsString();
  for (int i = 0; i < static_cast<int>(spec.choices.size()) && spec.choices[i] != nullptr; ++i) {
    if (word == spec.choices[i]) return i;
  }
  v->Fail("must be " + ChoiceWords(spec) + ", got '" + word + "'");
}

bool ReadBool(const Map& map, const KeySpec& spec) {
  const std::string leaf = LeafOf(spec);
  if (spec.required) return map.Required(leaf).AsBool();
  if (auto v = map.Optional(leaf)) return v->AsBool();
  return spec.default_bool;
}

std::string ReadText(const Map& map, const KeySpec& spec) {
  const std::string leaf = LeafOf(spec);
  if (spec.required) return map.Required(leaf).AsString();
  if (auto v = map.Optional(leaf)) return v->AsString();
  return spec.default_text;
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

Eigen::Vector2d ReadPair(const Map& map, const KeySpec& spec) {
  const std::string leaf = LeafOf(spec);
  const auto check = [&spec](const Field& f) { return Checked(f, spec); };
  std::optional<Field> v = spec.required ? std::optional<Field>(map.Required(leaf)) : map.Optional(leaf);
  if (!v) return {spec.default_pair[0], spec.default_pair[1]};
  const DofVector pair = ReadDofVector(*v, 2, check);
  return {pair(0), pair(1)};
}

Eigen::Vector2d ReadDirection(const Map& map, const KeySpec& spec) {
  const Eigen::Vector2d v = ReadPair(map, spec);
  if (!(v.norm() > 0.0)) map.Required(LeafOf(spec)).Fail("must be a non-zero direction");
  return v.normalized();
}

DofVector ReadDofValue(const Map& map, const KeySpec& spec, int dof) {
  const std::string leaf = LeafOf(spec);
  const auto check = [&spec](const Field& f) { return Checked(f, spec); };
  if (spec.required) return ReadDofVector(map.Required(leaf), dof, check);
  if (auto v = map.Optional(leaf)) return ReadDofVector(*v, dof, check);
  return DofVector::Constant(dof, spec.default_value);
}

}  // namespace teleop::config
