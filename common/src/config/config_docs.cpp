#include "teleop/config/config_docs.hpp"

#include <algorithm>
#include <cstddef>
#include <map>
#include <optional>

#include "teleop/config/delay_recheck_keys.hpp"
#include "teleop/config/key_table.hpp"
#include "teleop/device/device_registry.hpp"

namespace teleop::config {

namespace {

constexpr std::string_view kMarkerStart = "<!-- keys:";
constexpr std::string_view kTableHeader =
    "| key | type, unit | default | range | meaning |\n| --- | --- | --- | --- | --- |\n";

/// Appends `spec`'s row to the section it belongs under, keeping the sections in the order they first appear.
void AddRow(std::vector<KeyRowsSection>& sections, const std::string& name, const KeySpec& spec) {
  auto it = std::find_if(sections.begin(), sections.end(), [&name](const KeyRowsSection& s) { return s.name == name; });
  if (it == sections.end()) it = sections.insert(sections.end(), KeyRowsSection{name, {}});
  it->rows.push_back(KeyTableRow(spec));
}

std::vector<std::string> SplitLines(std::string_view text) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) {
      lines.emplace_back(text.substr(start));
      break;
    }
    lines.emplace_back(text.substr(start, end - start));
    start = end + 1;
  }
  return lines;
}

/// A marker line: the section's name and whether it is the begin marker.
struct Marker {
  std::string name;
  bool begin = false;
};

/// The marker on `line`, if it is one; a line that starts like one and is not well formed is an error.
std::optional<Marker> ParseMarker(const std::string& line, std::size_t number, std::vector<std::string>& errors) {
  if (line.rfind(kMarkerStart, 0) != 0) return std::nullopt;
  const std::size_t name_end = line.find(' ', kMarkerStart.size());
  const std::string name = line.substr(kMarkerStart.size(), name_end - kMarkerStart.size());
  const std::string rest = name_end == std::string::npos ? "" : line.substr(name_end + 1);
  const bool begin = rest.rfind("begin", 0) == 0;
  if (name.empty() || (!begin && rest.rfind("end", 0) != 0) || line.find("-->") == std::string::npos) {
    errors.push_back("line " + std::to_string(number) + ": a malformed marker '" + line +
                     "': write <!-- keys:NAME begin --> or <!-- keys:NAME end -->");
    return std::nullopt;
  }
  return Marker{name, begin};
}

/// A heading line's level and its backquoted name ("### `device.hybrid`": 3, "device.hybrid"); level 0 for other lines.
struct Heading {
  int level = 0;
  std::string name;
};

Heading ParseHeading(const std::string& line) {
  std::size_t level = 0;
  while (level < line.size() && line[level] == '#') ++level;
  if (level == 0 || level >= line.size() || line[level] != ' ') return {};
  const std::string text = line.substr(level + 1);
  const bool quoted = text.size() > 2 && text.front() == '`' && text.back() == '`';
  return {static_cast<int>(level), quoted ? text.substr(1, text.size() - 2) : ""};
}

/// Each line's heading, or level 0 (a line inside a ``` fence is never a heading: YAML comments start with '#').
std::vector<Heading> Headings(const std::vector<std::string>& lines) {
  std::vector<Heading> headings(lines.size());
  bool fenced = false;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].rfind("```", 0) == 0) fenced = !fenced;
    if (!fenced) headings[i] = ParseHeading(lines[i]);
  }
  return headings;
}

/// The marker blocks of `lines` by name: the line indices of the begin and end markers.
struct Block {
  std::size_t begin = 0;
  std::size_t end = 0;
};

std::map<std::string, Block> FindBlocks(const std::vector<std::string>& lines, std::vector<std::string>& errors) {
  std::map<std::string, Block> blocks;
  std::optional<std::pair<std::string, std::size_t>> open;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::optional<Marker> marker = ParseMarker(lines[i], i + 1, errors);
    if (!marker) continue;
    const std::string at = "line " + std::to_string(i + 1) + ": ";
    if (marker->begin) {
      if (open) {
        errors.push_back(at + "the begin marker of '" + marker->name + "' inside the block of '" + open->first +
                         "' (line " + std::to_string(open->second + 1) +
                         "), whose end marker <!-- keys:" + open->first + " end --> is missing");
      }
      open = {marker->name, i};
    } else if (!open || open->first != marker->name) {
      errors.push_back(at + "the end marker of '" + marker->name + "' without its begin marker");
    } else {
      if (blocks.count(marker->name) != 0) {
        errors.push_back(at + "the markers of '" + marker->name + "' a second time (first at line " +
                         std::to_string(blocks[marker->name].begin + 1) + "): keep one block");
      } else {
        blocks[marker->name] = {open->second, i};
      }
      open.reset();
    }
  }
  if (open) {
    errors.push_back("line " + std::to_string(open->second + 1) + ": the begin marker of '" + open->first +
                     "' has no end marker <!-- keys:" + open->first + " end -->");
  }
  return blocks;
}

void AppendBlockLines(std::vector<std::string>& out, const KeyRowsSection& section) {
  for (std::string& line : SplitLines(KeyTableBlock(section))) out.push_back(std::move(line));
}

/// Adds a heading and the marker block of `section`, which has neither, at the end of its nearest parent heading's
/// text (after the parent's sub-sections); false when no parent has a heading.
bool InsertSection(std::vector<std::string>& lines, const KeyRowsSection& section) {
  const std::vector<Heading> headings = Headings(lines);
  for (std::string parent = section.name; parent.find('.') != std::string::npos;) {
    parent.erase(parent.rfind('.'));
    const auto at = std::find_if(headings.begin(), headings.end(),
                                 [&parent](const Heading& h) { return h.level > 0 && h.name == parent; });
    if (at == headings.end()) continue;
    const int level = at->level;
    auto end = static_cast<std::size_t>(at - headings.begin()) + 1;
    while (end < lines.size() && !(headings[end].level > 0 && headings[end].level <= level &&
                                   headings[end].name.rfind(parent + ".", 0) != 0)) {
      ++end;
    }
    std::vector<std::string> added;
    if (end > 0 && !lines[end - 1].empty()) added.emplace_back();
    added.push_back(std::string(static_cast<std::size_t>(level < 3 ? level + 1 : level), '#') + " `" + section.name +
                    "`");
    added.emplace_back();
    AppendBlockLines(added, section);
    if (end < lines.size()) added.emplace_back();
    lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(end), added.begin(), added.end());
    return true;
  }
  return false;
}

}  // namespace

std::vector<KeyRowsSection> KeyTableDocsSections() {
  std::vector<KeyRowsSection> sections;
  for (const std::string& name : device::RegisteredDevices()) {
    for (const KeySpec& spec : device::FindDevice(name)->key_table) {
      AddRow(sections, DocsSectionOf("device." + name, spec), spec);
    }
  }
  for (const KeySpec* spec : delay_recheck_keys::kAll)
    AddRow(sections, DocsSectionOf("link.delay_recheck", *spec), *spec);
  return sections;
}

std::string KeyTableBlock(const KeyRowsSection& section) {
  std::string block = std::string(kMarkerStart) + section.name +
                      " begin (generated from the key table: cmake --build build --target config-docs) -->\n\n" +
                      std::string(kTableHeader);
  for (const std::string& row : section.rows) block += row + "\n";
  return block + "\n" + std::string(kMarkerStart) + section.name + " end -->\n";
}

KeyTablesRewrite RewriteKeyTables(std::string_view docs, const std::vector<KeyRowsSection>& sections) {
  KeyTablesRewrite result{std::string(docs), {}};
  const std::vector<std::string> lines = SplitLines(docs);
  const std::map<std::string, Block> blocks = FindBlocks(lines, result.errors);
  for (const auto& [name, block] : blocks) {
    const bool known = std::any_of(sections.begin(), sections.end(),
                                   [&name = name](const KeyRowsSection& s) { return s.name == name; });
    if (!known) {
      result.errors.push_back("line " + std::to_string(block.begin + 1) + ": the markers of '" + name +
                              "', which no key table has (a table or section removed, or a misspelt name): delete "
                              "the block or fix the name");
    }
  }
  // A section written with a heading of its own but no markers: where its table goes is for the writer to say.
  const std::vector<Heading> headings = Headings(lines);
  for (const KeyRowsSection& section : sections) {
    if (blocks.count(section.name) != 0) continue;
    for (std::size_t i = 0; i < lines.size(); ++i) {
      if (headings[i].level > 0 && headings[i].name == section.name) {
        result.errors.push_back("line " + std::to_string(i + 1) + ": the heading of '" + section.name +
                                "' has no markers: put <!-- keys:" + section.name + " begin --> and <!-- keys:" +
                                section.name + " end --> where its table goes (the generator fills them)");
      }
    }
  }
  if (!result.errors.empty()) return result;

  std::vector<std::string> out;
  out.reserve(lines.size());
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto block = std::find_if(blocks.begin(), blocks.end(), [i](const auto& b) { return b.second.begin == i; });
    if (block == blocks.end()) {
      out.push_back(lines[i]);
      continue;
    }
    AppendBlockLines(out, *std::find_if(sections.begin(), sections.end(),
                                        [&block](const KeyRowsSection& s) { return s.name == block->first; }));
    i = block->second.end;
  }
  // Sections with neither heading nor markers (a new backend's): parents before their sub-sections.
  std::vector<const KeyRowsSection*> missing;
  for (const KeyRowsSection& section : sections) {
    if (blocks.count(section.name) == 0) missing.push_back(&section);
  }
  std::stable_sort(missing.begin(), missing.end(), [](const KeyRowsSection* a, const KeyRowsSection* b) {
    return std::count(a->name.begin(), a->name.end(), '.') < std::count(b->name.begin(), b->name.end(), '.');
  });
  for (const KeyRowsSection* section : missing) {
    if (!InsertSection(out, *section)) {
      result.errors.push_back("'" + section->name +
                              "' has no markers and no parent section has a heading to put them under: add a "
                              "heading with <!-- keys:" +
                              section->name + " begin --> and <!-- keys:" + section->name + " end -->");
    }
  }
  if (!result.errors.empty()) return result;
  result.text.clear();
  for (const std::string& line : out) result.text += line + "\n";
  if (!docs.empty() && docs.back() != '\n' && !result.text.empty()) result.text.pop_back();
  return result;
}

}  // namespace teleop::config
