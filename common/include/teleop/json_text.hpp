#pragma once

#include <fmt/format.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace teleop {

namespace json_text_detail {

/// The length of the valid UTF-8 sequence at text[i] (1..4), or 0 when the bytes there are not one (a stray
/// continuation byte, a truncated sequence, an overlong form, a surrogate, or beyond U+10FFFF; RFC 3629 section 4).
inline std::size_t Utf8SequenceLength(std::string_view text, std::size_t i, std::uint32_t& code_point) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char b0 = byte(i);
  std::size_t n = 0;
  std::uint32_t min = 0;
  if (b0 < 0x80) {
    code_point = b0;
    return 1;
  }
  if ((b0 & 0xE0U) == 0xC0U) {
    n = 2;
    min = 0x80;
    code_point = b0 & 0x1FU;
  } else if ((b0 & 0xF0U) == 0xE0U) {
    n = 3;
    min = 0x800;
    code_point = b0 & 0x0FU;
  } else if ((b0 & 0xF8U) == 0xF0U) {
    n = 4;
    min = 0x10000;
    code_point = b0 & 0x07U;
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  for (std::size_t k = 1; k < n; ++k) {
    const unsigned char b = byte(i + k);
    if ((b & 0xC0U) != 0x80U) return 0;
    code_point = (code_point << 6U) | (b & 0x3FU);
  }
  if (code_point < min || code_point > 0x10FFFF || (code_point >= 0xD800 && code_point <= 0xDFFF)) return 0;
  return n;
}

}  // namespace json_text_detail

/// `text` as a JSON string literal (quotes included), the one escaper of the project (the run summary, the DDS
/// views and record, the dashboard's WebSocket): quote, backslash and control characters escaped (\n, \r, \t, else
/// \u00XX, DEL too); <, >, &, ' and U+2028/U+2029 as \uXXXX (so the text is inert even where it ends up inside HTML
/// or a script); every byte that is not part of valid UTF-8 replaced by U+FFFD (JSON is UTF-8, and a WebSocket
/// text frame must be: a browser drops the connection otherwise). What a JSON parser reads back is `text` itself
/// whenever `text` is valid UTF-8.
inline std::string JsonString(std::string_view text) {
  std::string out = "\"";
  out.reserve(text.size() + 2);
  std::size_t i = 0;
  while (i < text.size()) {
    std::uint32_t cp = 0;
    const std::size_t n = json_text_detail::Utf8SequenceLength(text, i, cp);
    if (n == 0) {
      out += "\\ufffd";  // not UTF-8: the replacement character, one per offending byte
      ++i;
      continue;
    }
    if (n > 1) {
      if (cp == 0x2028 || cp == 0x2029) {
        out += fmt::format("\\u{:04x}", cp);
      } else {
        out.append(text.substr(i, n));
      }
      i += n;
      continue;
    }
    const char c = text[i++];
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
      case '<':
      case '>':
      case '&':
      case '\'':
        out += fmt::format("\\u{:04x}", static_cast<unsigned>(c));
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7F) {
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
