// The generator of the key tables' rows in docs/configuration.md (teleop/config/config_docs.hpp) on small texts: it
// rewrites what is between a section's markers and nothing else, adds a new section under its parent's heading, and
// names every marker it cannot use instead of guessing.

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "teleop/config/config_docs.hpp"

namespace teleop::config {
namespace {

const std::vector<KeyRowsSection> kSections = {
    {"dev.a", {"| `x_m` | number, m | 1 | > 0 | X. |", "| `sub` | mapping |  |  | The sub.* keys. |"}},
    {"dev.a.sub", {"| `y_s` | number, s | **required** | ≥ 0 | Y. |"}},
};

const std::string kBeginA =
    "<!-- keys:dev.a begin (generated from the key table: cmake --build build --target config-docs) -->";
const std::string kTableA =
    "| key | type, unit | default | range | meaning |\n"
    "| --- | --- | --- | --- | --- |\n"
    "| `x_m` | number, m | 1 | > 0 | X. |\n"
    "| `sub` | mapping |  |  | The sub.* keys. |\n";
const std::string kBlockA = kBeginA + "\n\n" + kTableA + "\n<!-- keys:dev.a end -->\n";

/// A docs page whose two sections have markers; `a_block` between dev.a's.
std::string Page(const std::string& a_block) {
  return "# Page\n\nProse before.\n\n## `dev`\n\n### `dev.a`\n\nHand-written prose of a.\n\n" + a_block +
         "\nA note after the table.\n\n### `dev.a.sub`\n\n<!-- keys:dev.a.sub begin -->\n<!-- keys:dev.a.sub end "
         "-->\n\n## `other`\n\n```yaml\n# a YAML comment, not a heading\n```\n";
}

/// The first error's text, or "" when there is none.
std::string FirstError(const KeyTablesRewrite& r) { return r.errors.empty() ? "" : r.errors.front(); }

TEST(KeyTablesDocs, TheBlockIsTheMarkersAroundTheHeaderAndTheRows) { EXPECT_EQ(KeyTableBlock(kSections[0]), kBlockA); }

TEST(KeyTablesDocs, StaleRowsBetweenTheMarkersAreReplacedAndTheProseIsKept) {
  const std::string stale =
      "<!-- keys:dev.a begin -->\n| `x_m` | number, m | 2 | > 0 | X. |\n<!-- keys:dev.a end -->\n";
  const KeyTablesRewrite r = RewriteKeyTables(Page(stale), kSections);
  ASSERT_TRUE(r.errors.empty()) << FirstError(r);
  const std::string sub_block =
      "<!-- keys:dev.a.sub begin (generated from the key table: cmake --build build --target config-docs) -->\n\n"
      "| key | type, unit | default | range | meaning |\n"
      "| --- | --- | --- | --- | --- |\n| `y_s` | number, s | **required** | ≥ 0 | Y. |\n\n<!-- keys:dev.a.sub end "
      "-->\n";
  const std::string expected = "# Page\n\nProse before.\n\n## `dev`\n\n### `dev.a`\n\nHand-written prose of a.\n\n" +
                               kBlockA + "\nA note after the table.\n\n### `dev.a.sub`\n\n" + sub_block +
                               "\n## `other`\n\n```yaml\n# a YAML comment, not a heading\n```\n";
  EXPECT_EQ(r.text, expected);
  // What the generator writes it leaves as it is: the currency check passes on its own output.
  const KeyTablesRewrite again = RewriteKeyTables(r.text, kSections);
  EXPECT_TRUE(again.errors.empty()) << FirstError(again);
  EXPECT_EQ(again.text, r.text);
  // A row changed in the table changes the page: the currency check fails on the old page.
  std::vector<KeyRowsSection> changed = kSections;
  changed[0].rows[0] = "| `x_m` | number, m | 3 | > 0 | X. |";
  EXPECT_NE(RewriteKeyTables(r.text, changed).text, r.text);
}

TEST(KeyTablesDocs, AMissingEndMarkerIsNamedAndNothingIsWritten) {
  const std::string page = Page("<!-- keys:dev.a begin -->\n| stale |\n");
  const KeyTablesRewrite r = RewriteKeyTables(page, kSections);
  ASSERT_FALSE(r.errors.empty());
  EXPECT_NE(FirstError(r).find("'dev.a'"), std::string::npos) << FirstError(r);
  EXPECT_NE(FirstError(r).find("<!-- keys:dev.a end -->"), std::string::npos) << FirstError(r);
  EXPECT_EQ(r.text, page);
}

TEST(KeyTablesDocs, AnEndWithoutItsBeginADuplicateAndAMalformedMarkerAreErrors) {
  const KeyTablesRewrite lone = RewriteKeyTables(Page("<!-- keys:dev.a end -->\n"), kSections);
  ASSERT_FALSE(lone.errors.empty());
  EXPECT_NE(FirstError(lone).find("end marker of 'dev.a' without its begin"), std::string::npos) << FirstError(lone);

  const KeyTablesRewrite twice = RewriteKeyTables(Page(kBlockA + "\n" + kBlockA), kSections);
  ASSERT_FALSE(twice.errors.empty());
  EXPECT_NE(FirstError(twice).find("'dev.a' a second time"), std::string::npos) << FirstError(twice);

  const KeyTablesRewrite bad = RewriteKeyTables(Page("<!-- keys:dev.a start -->\n" + kBlockA), kSections);
  ASSERT_FALSE(bad.errors.empty());
  EXPECT_NE(FirstError(bad).find("malformed marker"), std::string::npos) << FirstError(bad);
}

TEST(KeyTablesDocs, MarkersOfASectionNoTableHasAreAnError) {
  const std::string page = Page(kBlockA + "\n<!-- keys:dev.gone begin -->\n<!-- keys:dev.gone end -->\n");
  const KeyTablesRewrite r = RewriteKeyTables(page, kSections);
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_NE(r.errors[0].find("'dev.gone', which no key table has"), std::string::npos) << r.errors[0];
  EXPECT_EQ(r.text, page);
}

TEST(KeyTablesDocs, AHeadingWithoutMarkersIsNamedWithTheMarkersToAdd) {
  // dev.a's heading is there, its markers are not (a hand table the generator must not guess at).
  const KeyTablesRewrite r = RewriteKeyTables(Page("| `x_m` | hand row |\n"), kSections);
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_NE(r.errors[0].find("line 7: the heading of 'dev.a' has no markers: put <!-- keys:dev.a begin -->"),
            std::string::npos)
      << r.errors[0];
}

TEST(KeyTablesDocs, ASectionWithNeitherHeadingNorMarkersIsAddedUnderItsParent) {
  // A new backend's table: dev.b and dev.b.sub have no heading; they go at the end of `dev` (after dev.a and its
  // sub-section, before `other`), dev.b.sub after dev.b; the '#' line in the YAML fence is not a heading.
  std::vector<KeyRowsSection> sections = kSections;
  sections.push_back({"dev.b.sub", {"| `z` | number | 0 | finite | Z. |"}});
  sections.push_back({"dev.b", {"| `w` | number | 0 | finite | W. |"}});
  const KeyTablesRewrite r = RewriteKeyTables(Page(kBlockA), sections);
  ASSERT_TRUE(r.errors.empty()) << FirstError(r);
  const auto a_sub = r.text.find("### `dev.a.sub`");
  const auto b = r.text.find("\n### `dev.b`\n\n<!-- keys:dev.b begin");
  const auto b_sub = r.text.find("\n### `dev.b.sub`\n\n<!-- keys:dev.b.sub begin");
  const auto other = r.text.find("\n## `other`");
  ASSERT_NE(b, std::string::npos) << r.text;
  ASSERT_NE(b_sub, std::string::npos) << r.text;
  EXPECT_LT(a_sub, b);
  EXPECT_LT(b, b_sub);
  EXPECT_LT(b_sub, other);
  EXPECT_NE(r.text.find("| `w` | number | 0 | finite | W. |\n\n<!-- keys:dev.b end -->\n\n### `dev.b.sub`"),
            std::string::npos)
      << r.text;
  EXPECT_NE(r.text.find("<!-- keys:dev.b.sub end -->\n\n## `other`"), std::string::npos) << r.text;
  const KeyTablesRewrite again = RewriteKeyTables(r.text, sections);
  EXPECT_TRUE(again.errors.empty()) << FirstError(again);
  EXPECT_EQ(again.text, r.text);
}

TEST(KeyTablesDocs, ASectionWithoutMarkersWhoseParentHasNoHeadingIsAnError) {
  std::vector<KeyRowsSection> sections = kSections;
  sections.push_back({"top.c", {"| `v` | number | 0 | finite | V. |"}});
  const std::string page = Page(kBlockA);
  const KeyTablesRewrite r = RewriteKeyTables(page, sections);
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_NE(r.errors[0].find("'top.c' has no markers and no parent section has a heading"), std::string::npos)
      << r.errors[0];
  EXPECT_EQ(r.text, page);
}

}  // namespace
}  // namespace teleop::config
