#pragma once

#include <CLI/CLI.hpp>
#include <cstddef>
#include <memory>
#include <sstream>
#include <string>

namespace teleop {

/// The widest line a tool's `--help` prints (tests/deploy/help_texts_test.py checks every tool against it).
inline constexpr std::size_t kHelpWidth = 120;

/// `text` with its lines broken at spaces so that none is longer than `width` (a word longer than that stays whole);
/// the line breaks already in it are kept.
inline std::string WrapHelpText(const std::string& text, std::size_t width) {
  std::string out;
  std::size_t line_start = 0;
  std::size_t last_space = std::string::npos;
  for (const char c : text) {
    if (c == '\n') {
      out += c;
      line_start = out.size();
      last_space = std::string::npos;
      continue;
    }
    out += c;
    if (c == ' ') last_space = out.size() - 1;
    if (out.size() - line_start > width && last_space != std::string::npos && last_space > line_start) {
      out[last_space] = '\n';
      line_start = last_space + 1;
      last_space = std::string::npos;
    }
  }
  return out;
}

/// A CLI11 formatter whose descriptions (the tool's, each option's, each subcommand's) are wrapped to kHelpWidth.
class WrappingHelpFormatter : public CLI::Formatter {
 public:
  std::string make_description(const CLI::App* app) const override {
    return WrapHelpText(CLI::Formatter::make_description(app), kHelpWidth);
  }
  std::string make_option_desc(const CLI::Option* opt) const override {
    return WrapHelpText(CLI::Formatter::make_option_desc(opt), DescriptionWidth());
  }
  /// The type, default and constraints after an option's name ("Excludes: ..." can be long): continued lines start
  /// at the description's column.
  std::string make_option_opts(const CLI::Option* opt) const override {
    const std::string opts = WrapHelpText(CLI::Formatter::make_option_opts(opt), DescriptionWidth());
    std::string out;
    for (const char c : opts) {
      out += c;
      if (c == '\n') out.append(get_column_width(), ' ');
    }
    return out;
  }
  std::string make_subcommand(const CLI::App* sub) const override {
    std::stringstream out;
    CLI::detail::format_help(out, sub->get_display_name(true), WrapHelpText(sub->get_description(), DescriptionWidth()),
                             get_column_width());
    return out.str();
  }
  std::string make_footer(const CLI::App* app) const override {
    return WrapHelpText(CLI::Formatter::make_footer(app), kHelpWidth);
  }

 private:
  std::size_t DescriptionWidth() const { return kHelpWidth - get_column_width(); }
};

/// What every tool's `--help` has: each option's default (CLI11 captures it when the
/// option is added, so call this before adding options and subcommands, which inherit both) and lines no wider than
/// kHelpWidth.
inline void StandardHelp(CLI::App& app) {
  app.option_defaults()->always_capture_default();
  app.formatter(std::make_shared<WrappingHelpFormatter>());
}

}  // namespace teleop
