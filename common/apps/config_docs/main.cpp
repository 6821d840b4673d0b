// teleop-config-docs FILE: rewrites the key tables' rows in docs/configuration.md (FILE) between their marker comments
// (teleop/config/config_docs.hpp), leaving the prose around them as written; `--check` only says whether FILE is
// current. The build target `config-docs` runs it on the source tree's docs/configuration.md.
#include <CLI/CLI.hpp>
#include <cstddef>
#include <exception>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/cli_help.hpp"
#include "teleop/config/config_docs.hpp"
#include "teleop/version.hpp"

int main(int argc, char** argv) {
  try {
    CLI::App app{"teleop-config-docs: write the key tables' rows into docs/configuration.md between their markers"};
    app.set_version_flag("--version", teleop::VersionText("teleop-config-docs"));
    teleop::StandardHelp(app);
    std::string path;
    bool check = false;
    app.add_option("path", path, "docs/configuration.md, rewritten in place")->required();
    app.add_flag("--check", check, "Write nothing; exit 1 when the file is not what the key tables make");
    CLI11_PARSE(app, argc, argv);

    std::ifstream in(path);
    if (!in) {
      std::cerr << "teleop-config-docs: cannot read " << path << "\n";
      return 1;
    }
    std::stringstream text;
    text << in.rdbuf();
    in.close();
    const std::string docs = text.str();
    const std::vector<teleop::config::KeyRowsSection> sections = teleop::config::KeyTableDocsSections();
    const teleop::config::KeyTablesRewrite rewrite = teleop::config::RewriteKeyTables(docs, sections);
    for (const std::string& error : rewrite.errors) std::cerr << path << ":" << error << "\n";
    if (!rewrite.errors.empty()) return 1;
    std::size_t rows = 0;
    for (const auto& section : sections) rows += section.rows.size();
    const std::string counts = std::to_string(sections.size()) + " sections, " + std::to_string(rows) + " rows";
    if (rewrite.text == docs) {
      std::cout << "teleop-config-docs: " << path << " is current (" << counts << ")\n";
      return 0;
    }
    if (check) {
      std::cout << "teleop-config-docs: " << path
                << " is not what the key tables make: run `cmake --build build --target config-docs`\n";
      return 1;
    }
    std::ofstream out(path, std::ios::trunc);
    out << rewrite.text;
    if (!out.flush()) {
      std::cerr << "teleop-config-docs: cannot write " << path << "\n";
      return 1;
    }
    std::cout << "teleop-config-docs: rewrote " << path << " (" << counts << ")\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "teleop-config-docs: " << e.what() << "\n";
    return 2;
  }
}
