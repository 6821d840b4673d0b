#pragma once

// Helpers for config-reader tests: edit a YAML text in place, find where a token is, and check that parsing fails
// with "FILE:LINE:COL: key 'KEY': reason".

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"

namespace teleop::test {

/// `text` with the first `from` replaced by `to` (a test failure when `from` is not there).
inline std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test bug: '" << from << "' not in the base config";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

/// 1-based "LINE:COL" of the first occurrence of `needle` in `text`.
inline std::string Where(const std::string& text, const std::string& needle) {
  const auto at = text.find(needle);
  EXPECT_NE(at, std::string::npos) << "test bug: '" << needle << "' not in the config";
  const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n');
  const auto line_start = text.rfind('\n', at);
  const auto column = line_start == std::string::npos ? at + 1 : at - line_start;
  return std::to_string(line) + ":" + std::to_string(column);
}

/// Parses `text` as "test.yaml" and returns the error message; fails the test when it parses.
inline std::string ErrorOf(const std::string& text) {
  try {
    (void)config::ParseProcessConfig(text, "test.yaml");
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected teleop::Error for:\n" << text;
  return {};
}

/// The message must start with "test.yaml:LINE:COL: key 'KEY': " (LINE:COL of `at_needle`) and contain `reason`.
inline void ExpectError(const std::string& text, const std::string& at_needle, const std::string& key,
                        const std::string& reason) {
  const std::string message = ErrorOf(text);
  const std::string prefix = "test.yaml:" + Where(text, at_needle) + ": key '" + key + "': ";
  EXPECT_EQ(message.rfind(prefix, 0), 0u) << "message: " << message << "\nexpected prefix: " << prefix;
  EXPECT_THAT(message, ::testing::HasSubstr(reason));
}

}  // namespace teleop::test
