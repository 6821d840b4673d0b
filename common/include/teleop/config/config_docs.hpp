#pragma once

// The key tables' rows in docs/configuration.md, generated: each table-driven section's table sits between two marker
// comments, `<!-- keys:device.hybrid.geometry begin ... -->` and `<!-- keys:device.hybrid.geometry end -->`, and
// `teleop-config-docs` (the build target `config-docs`) rewrites what is between them from the key tables; the prose
// outside the markers is left as written. config_docs_test fails when the file is not what the generator writes.

#include <string>
#include <string_view>
#include <vector>

namespace teleop::config {

/// The rows of one docs section: `name` is its dotted path ("device.hybrid.geometry", the heading's text without the
/// backquotes), `rows` its KeyTableRow lines in table order.
struct KeyRowsSection {
  std::string name;
  std::vector<std::string> rows;
};

/// Every table-driven section: each registered device backend's key table, split by DocsSectionOf, and the
/// link.delay_recheck table, in that order.
std::vector<KeyRowsSection> KeyTableDocsSections();

/// What RewriteKeyTables made: the new text, and what kept it from being made (then `text` is the input unchanged).
struct KeyTablesRewrite {
  std::string text;
  std::vector<std::string> errors;  ///< "line 12: ...": each names the marker and what to do.
};

/// `docs` with each section's marker block replaced by the section's table (header and rows); a section without
/// markers gets a new "### `name`" heading with its block at the end of its nearest parent's heading (after the
/// parent's own sub-sections). Errors: a begin without its end (or an end without a begin), a marker given twice, a
/// marker for no section (a removed table: delete the block), a section without markers whose parent has no heading.
KeyTablesRewrite RewriteKeyTables(std::string_view docs, const std::vector<KeyRowsSection>& sections);

/// The marker block of `section` as RewriteKeyTables writes it (begin line, blank, table, blank, end line).
std::string KeyTableBlock(const KeyRowsSection& section);

}  // namespace teleop::config
