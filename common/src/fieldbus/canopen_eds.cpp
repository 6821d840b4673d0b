#include "teleop/fieldbus/canopen_eds.hpp"

#include <fmt/format.h>

#include <algorithm>
// Boost.MultiIndex (under property_tree) trips -Wnull-dereference in its own inlined node code (GCC 12, -O3); not
// ours to fix.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wnull-dereference"
#endif
#include <boost/property_tree/ini_parser.hpp>
#include <boost/property_tree/ptree.hpp>
#include <cctype>
#include <fstream>
#include <sstream>

#include "teleop/error.hpp"

namespace teleop::fieldbus::canopen {

namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string Trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return {};
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

bool ParseHex(const std::string& s, std::uint32_t& out) {
  if (s.empty() || s.size() > 8) return false;
  std::uint32_t v = 0;
  for (const char c : s) {
    if (!std::isxdigit(static_cast<unsigned char>(c))) return false;
    v = v << 4 |
        static_cast<std::uint32_t>(std::isdigit(static_cast<unsigned char>(c)) ? c - '0' : std::tolower(c) - 'a' + 10);
  }
  out = v;
  return true;
}

/// "1018" → (0x1018, 0, true); "1018sub1" → (0x1018, 1, true) (CiA 306: the sub-index in hex after "sub").
bool ParseSectionName(const std::string& name, std::uint16_t& index, std::uint8_t& sub, bool& is_sub) {
  const std::string n = Lower(name);
  const auto at = n.find("sub");
  std::uint32_t i = 0;
  if (!ParseHex(n.substr(0, at == std::string::npos ? n.size() : at), i) || i > 0xFFFF) return false;
  index = static_cast<std::uint16_t>(i);
  is_sub = at != std::string::npos;
  sub = 0;
  if (is_sub) {
    std::uint32_t s = 0;
    if (!ParseHex(n.substr(at + 3), s) || s > 0xFF) return false;
    sub = static_cast<std::uint8_t>(s);
  }
  return true;
}

}  // namespace

bool ParseEdsValue(const std::string& text, std::uint8_t node_id, std::uint32_t& value) noexcept {
  const std::string t = Trim(text);
  if (t.empty()) return false;
  std::uint64_t sum = 0;
  std::size_t start = 0;
  while (start <= t.size()) {
    const std::size_t plus = t.find('+', start);
    const std::string term = Trim(t.substr(start, plus == std::string::npos ? std::string::npos : plus - start));
    if (term.empty()) return false;
    if (Lower(term) == "$nodeid") {
      sum += node_id;
    } else {
      std::uint32_t v = 0;
      if (term.size() > 2 && term[0] == '0' && (term[1] == 'x' || term[1] == 'X')) {
        if (!ParseHex(term.substr(2), v)) return false;
      } else {
        const bool octal = term.size() > 1 && term[0] == '0';
        std::uint64_t acc = 0;
        std::size_t k = 0;
        const bool negative = term[0] == '-';
        if (negative) k = 1;
        if (k >= term.size()) return false;
        for (; k < term.size(); ++k) {
          const char c = term[k];
          if (!std::isdigit(static_cast<unsigned char>(c)) || (octal && c > '7')) return false;
          acc = acc * (octal ? 8 : 10) + static_cast<std::uint64_t>(c - '0');
          if (acc > 0xFFFF'FFFFull) return false;
        }
        v = negative ? static_cast<std::uint32_t>(-static_cast<std::int64_t>(acc)) : static_cast<std::uint32_t>(acc);
      }
      sum += v;
    }
    if (plus == std::string::npos) break;
    start = plus + 1;
  }
  value = static_cast<std::uint32_t>(sum);
  return true;
}

std::string DataTypeName(std::uint16_t type) {
  switch (type) {
    case datatype::kBoolean:
      return "BOOLEAN";
    case datatype::kInteger8:
      return "INTEGER8";
    case datatype::kInteger16:
      return "INTEGER16";
    case datatype::kInteger32:
      return "INTEGER32";
    case datatype::kUnsigned8:
      return "UNSIGNED8";
    case datatype::kUnsigned16:
      return "UNSIGNED16";
    case datatype::kUnsigned32:
      return "UNSIGNED32";
    case datatype::kReal32:
      return "REAL32";
    case datatype::kVisibleString:
      return "VISIBLE_STRING";
    case datatype::kOctetString:
      return "OCTET_STRING";
    case datatype::kDomain:
      return "DOMAIN";
    default:
      return fmt::format("0x{:04X}", type);
  }
}

bool EdsEntry::readable() const noexcept {
  return access == "ro" || access == "rw" || access == "rwr" || access == "rww" || access == "const";
}
bool EdsEntry::writable() const noexcept {
  return access == "wo" || access == "rw" || access == "rwr" || access == "rww";
}

Eds Eds::Load(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(fmt::format("EDS {}: cannot open the file", path));
  std::stringstream text;
  text << in.rdbuf();
  return Parse(text.str(), path);
}

Eds Eds::Parse(const std::string& text, const std::string& file) {
  namespace pt = boost::property_tree;
  pt::ptree tree;
  try {
    std::istringstream in(text);
    pt::ini_parser::read_ini(in, tree);
  } catch (const pt::ini_parser_error& e) {
    throw Error(fmt::format("EDS {}: line {}: {}", file, e.line(), e.message()));
  }
  Eds eds;
  eds.file_ = file;
  auto number = [&](const std::string& section, const std::string& key, const std::string& value) {
    std::uint32_t v = 0;
    if (!ParseEdsValue(value, 0, v)) {
      throw Error(fmt::format("EDS {}: [{}] {}: '{}' is not a number", file, section, key, value));
    }
    return v;
  };
  for (const auto& [section, body] : tree) {
    const std::string lower = Lower(section);
    if (lower == "deviceinfo") {
      for (const auto& [key, value] : body) {
        if (Lower(key) == "nrofrxpdo") eds.rx_pdos_ = static_cast<int>(number(section, key, value.data()));
        if (Lower(key) == "nroftxpdo") eds.tx_pdos_ = static_cast<int>(number(section, key, value.data()));
      }
      continue;
    }
    std::uint16_t index = 0;
    std::uint8_t sub = 0;
    bool is_sub = false;
    if (!ParseSectionName(section, index, sub, is_sub)) continue;  // FileInfo, Comments, lists, …
    if (section.size() != 4 && !is_sub) continue;
    EdsEntry e;
    e.index = index;
    e.subindex = sub;
    e.section = section;
    for (const auto& [key, value] : body) {
      const std::string k = Lower(key);
      const std::string v = Trim(value.data());
      if (k == "parametername") e.name = v;
      if (k == "objecttype") e.object_type = static_cast<std::uint8_t>(number(section, key, v));
      if (k == "datatype") e.data_type = static_cast<std::uint16_t>(number(section, key, v));
      if (k == "accesstype") e.access = Lower(v);
      if (k == "defaultvalue") e.default_value = v;
      if (k == "pdomapping") e.pdo_mapping = number(section, key, v) != 0;
      if (k == "subnumber") e.sub_number = static_cast<int>(number(section, key, v));
    }
    eds.objects_[index] = true;
    // A VAR's section is its sub 0; an ARRAY/RECORD's top holds only SubNumber (its sub-objects have sections).
    if (is_sub || e.object_type == 0x7) eds.entries_[std::uint32_t{index} << 8 | sub] = e;
  }
  if (eds.entries_.empty()) throw Error(fmt::format("EDS {}: no object sections ([1000], [1018sub1], …)", file));
  return eds;
}

const EdsEntry* Eds::Find(std::uint16_t index, std::uint8_t subindex) const noexcept {
  const auto it = entries_.find(std::uint32_t{index} << 8 | subindex);
  return it == entries_.end() ? nullptr : &it->second;
}

bool Eds::Has(std::uint16_t index) const noexcept { return objects_.count(index) != 0; }

int Eds::MappingCapacity(std::uint16_t mapping_index) const noexcept {
  int highest = 0;
  for (int s = 1; s <= 0x40; ++s) {
    if (Find(mapping_index, static_cast<std::uint8_t>(s)) != nullptr) highest = s;
  }
  return highest;
}

std::optional<std::uint32_t> Eds::DefaultValue(std::uint16_t index, std::uint8_t subindex, std::uint8_t node_id) const {
  const EdsEntry* e = Find(index, subindex);
  if (e == nullptr || e->default_value.empty()) return std::nullopt;
  std::uint32_t v = 0;
  if (!ParseEdsValue(e->default_value, node_id, v)) {
    throw Error(fmt::format("EDS {}: [{}] DefaultValue: '{}' is not a number", file_, e->section, e->default_value));
  }
  return v;
}

}  // namespace teleop::fieldbus::canopen
