#pragma once

#include <fmt/format.h>

#include <string>
#include <string_view>

namespace teleop {

/// `text` as a JSON string literal (quotes included): quote, backslash and control characters escaped (\n, \r, \t,
/// else \u00XX). The one escaper of the run summary (node/run_summary.cpp) and the DDS views (dds/process_view.cpp).
inline std::string JsonString(std::string_view text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          out += fmt::format("\\u{:04x}", static_cast<unsigned>(static_cast<unsigned char>(c)));
        } else {
          out += c;
        }
    }
  }
  out += '"';
  return out;
}

}  // namespace teleop
