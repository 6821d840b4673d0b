#include "teleop/transport/can_log.hpp"

#include <cerrno>
#include <charconv>
#include <cstring>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::transport {

using proto::can::CanFrame;

namespace {

constexpr std::uint32_t kErrFlag = 0x2000'0000u;  // CAN_ERR_FLAG
constexpr char kHex[] = "0123456789ABCDEF";

/// Appends to a fixed buffer; `ok` turns false on overflow.
struct Out {
  std::span<char> buf;
  std::size_t n = 0;
  bool ok = true;
  void Put(char c) noexcept {
    if (n < buf.size()) {
      buf[n++] = c;
    } else {
      ok = false;
    }
  }
  void Text(std::string_view s) noexcept {
    for (const char c : s) Put(c);
  }
  void Hex(std::uint32_t value, int digits) noexcept {
    for (int i = digits - 1; i >= 0; --i) Put(kHex[(value >> (4 * i)) & 0xFu]);
  }
  void Decimal(std::uint64_t value, int digits) noexcept {
    char tmp[20];
    for (int i = digits - 1; i >= 0; --i) {
      tmp[i] = static_cast<char>('0' + value % 10);
      value /= 10;
    }
    for (int i = 0; i < digits; ++i) Put(tmp[i]);
  }
};

int HexValue(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

bool ParseHex(std::string_view s, std::uint32_t& out) noexcept {
  if (s.empty() || s.size() > 8) return false;
  out = 0;
  for (const char c : s) {
    const int v = HexValue(c);
    if (v < 0) return false;
    out = out << 4 | static_cast<std::uint32_t>(v);
  }
  return true;
}

bool ParseData(std::string_view s, CanFrame& frame, std::size_t max) noexcept {
  if (s.size() % 2 != 0 || s.size() / 2 > max) return false;
  frame.len = static_cast<std::uint8_t>(s.size() / 2);
  for (std::size_t i = 0; i < frame.len; ++i) {
    const int hi = HexValue(s[2 * i]);
    const int lo = HexValue(s[2 * i + 1]);
    if (hi < 0 || lo < 0) return false;
    frame.data[i] = static_cast<std::uint8_t>(hi << 4 | lo);
  }
  return true;
}

}  // namespace

std::size_t FormatCandumpLine(const CanFrame& frame, std::uint64_t time_ns, std::string_view interface_name,
                              std::span<char> out) noexcept {
  Out o{out};
  const std::uint64_t us = time_ns / 1000;
  o.Put('(');
  o.Decimal(us / 1'000'000, 10);
  o.Put('.');
  o.Decimal(us % 1'000'000, 6);
  o.Text(") ");
  o.Text(interface_name);
  o.Put(' ');
  const std::size_t len = frame.fd ? std::min<std::size_t>(frame.len, proto::can::kFdMaxDataBytes)
                                   : std::min<std::size_t>(frame.len, proto::can::kClassicMaxDataBytes);
  if (frame.error) {
    o.Hex(kErrFlag | (frame.error_class & 0x1FFF'FFFFu), 8);
    o.Put('#');
    for (std::size_t i = 0; i < proto::can::kClassicMaxDataBytes; ++i) o.Hex(frame.data[i], 2);
  } else {
    if (frame.extended) {
      o.Hex(frame.id & proto::can::kMaxExtendedId, 8);
    } else {
      o.Hex(frame.id & proto::can::kMaxStandardId, 3);
    }
    o.Put('#');
    if (frame.fd) {
      o.Put('#');
      o.Hex(frame.brs ? 1u : 0u, 1);
    } else if (frame.remote) {
      o.Put('R');
    }
    if (!frame.remote || frame.fd) {
      for (std::size_t i = 0; i < len; ++i) o.Hex(frame.data[i], 2);
    }
  }
  o.Put('\n');
  return o.ok ? o.n : 0;
}

bool ParseCandumpLine(std::string_view line, CanFrame& frame, std::uint64_t& time_ns, std::string& interface_name) {
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r')) line.remove_suffix(1);
  if (line.size() < 4 || line.front() != '(') return false;
  const std::size_t close = line.find(") ");
  const std::size_t dot = line.find('.');
  if (close == std::string_view::npos || dot == std::string_view::npos || dot > close) return false;
  std::uint64_t sec = 0;
  std::uint64_t usec = 0;
  const std::string_view sec_text = line.substr(1, dot - 1);
  const std::string_view usec_text = line.substr(dot + 1, close - dot - 1);
  if (usec_text.size() != 6) return false;
  if (std::from_chars(sec_text.data(), sec_text.data() + sec_text.size(), sec).ec != std::errc{}) return false;
  if (std::from_chars(usec_text.data(), usec_text.data() + usec_text.size(), usec).ec != std::errc{}) return false;
  time_ns = (sec * 1'000'000 + usec) * 1000;
  std::string_view rest = line.substr(close + 2);
  const std::size_t space = rest.find(' ');
  if (space == std::string_view::npos || space == 0) return false;
  interface_name.assign(rest.substr(0, space));
  rest = rest.substr(space + 1);
  const std::size_t hash = rest.find('#');
  if (hash == std::string_view::npos) return false;
  const std::string_view id_text = rest.substr(0, hash);
  std::string_view data = rest.substr(hash + 1);
  frame = CanFrame{};
  std::uint32_t id = 0;
  if (!ParseHex(id_text, id)) return false;
  if (id_text.size() == 8 && (id & kErrFlag) != 0) {
    frame.error = true;
    frame.error_class = id & ~kErrFlag;
    return ParseData(data, frame, proto::can::kClassicMaxDataBytes);
  }
  if (id_text.size() == 3) {
    if (id > proto::can::kMaxStandardId) return false;
  } else if (id_text.size() == 8) {
    if (id > proto::can::kMaxExtendedId) return false;
    frame.extended = true;
  } else {
    return false;
  }
  frame.id = id;
  if (!data.empty() && data.front() == '#') {
    if (data.size() < 2) return false;
    const int flags = HexValue(data[1]);
    if (flags < 0) return false;
    frame.fd = true;
    frame.brs = (flags & 1) != 0;
    return ParseData(data.substr(2), frame, proto::can::kFdMaxDataBytes) && proto::can::IsValidFdLength(frame.len);
  }
  if (!data.empty() && (data.front() == 'R' || data.front() == 'r')) {
    frame.remote = true;
    return true;
  }
  return ParseData(data, frame, proto::can::kClassicMaxDataBytes);
}

CandumpLogWriter::CandumpLogWriter(const std::string& path, std::string interface_name)
    : path_(path), interface_name_(std::move(interface_name)) {
  if (interface_name_.empty() || interface_name_.size() > 16 || interface_name_.find(' ') != std::string::npos) {
    throw Error("candump log: interface name '" + interface_name_ + "' must be 1..16 characters without spaces");
  }
  file_ = std::fopen(path.c_str(), "w");
  if (file_ == nullptr) throw Error("candump log: cannot open " + path + ": " + std::strerror(errno));
}

CandumpLogWriter::~CandumpLogWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

bool CandumpLogWriter::Write(const CanFrame& frame, std::uint64_t time_ns) noexcept {
  std::array<char, kMaxCandumpLineBytes> line{};
  const std::size_t n = FormatCandumpLine(frame, time_ns, interface_name_, line);
  if (n == 0 || std::fwrite(line.data(), 1, n, file_) != n) {
    ++write_errors_;
    return false;
  }
  ++lines_;
  return true;
}

void CandumpLogWriter::Flush() noexcept { std::fflush(file_); }

}  // namespace teleop::transport
