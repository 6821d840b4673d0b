#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <string_view>

#include "teleop/proto/can/can_frame.hpp"

namespace teleop::transport {

/// The longest candump -L line this writer produces (64-byte FD frame, 16-character interface name), newline included.
inline constexpr std::size_t kMaxCandumpLineBytes = 200;

/// Formats `frame` as one line of can-utils' `candump -L` log format (what `canplayer` and `log2asc` read):
///   "(ssssssssss.uuuuuu) IFACE ID#DATA\n"
/// ID is 3 hex digits for 11-bit, 8 for 29-bit identifiers; classic data as "123#DEADBEEF", remote as "123#R",
/// FD as "123##<flags nibble>DATA" (bit 0 BRS, bit 1 ESI), error frames as the 8-digit CAN_ERR_FLAG identifier
/// (0x20000000 | error class) with their 8 data bytes, as candump prints them. `time_ns` is written in seconds with
/// microseconds. Returns the bytes written to `out` (0 when `out` is smaller than the line). No allocation.
std::size_t FormatCandumpLine(const proto::can::CanFrame& frame, std::uint64_t time_ns, std::string_view interface_name,
                              std::span<char> out) noexcept;

/// Parses one candump -L line (the inverse of FormatCandumpLine; also reads lines of candump itself, whose FD flags
/// nibble may carry the kernel's FDF bit). False for anything malformed. Set-up/test use: `interface_name` allocates.
bool ParseCandumpLine(std::string_view line, proto::can::CanFrame& frame, std::uint64_t& time_ns,
                      std::string& interface_name);

/// A candump -L log file: one FormatCandumpLine per frame. For tests, the teleop-canbus daemon and tools (not the
/// control cycle: writing is buffered stdio). Throws teleop::Error when the file cannot be opened.
class CandumpLogWriter {
 public:
  CandumpLogWriter(const std::string& path, std::string interface_name);
  ~CandumpLogWriter();
  CandumpLogWriter(const CandumpLogWriter&) = delete;
  CandumpLogWriter& operator=(const CandumpLogWriter&) = delete;

  /// Appends one line. False when the write failed (disk full): counted in write_errors().
  bool Write(const proto::can::CanFrame& frame, std::uint64_t time_ns) noexcept;
  void Flush() noexcept;
  std::uint64_t lines() const noexcept { return lines_; }
  std::uint64_t write_errors() const noexcept { return write_errors_; }
  const std::string& path() const noexcept { return path_; }

 private:
  std::FILE* file_ = nullptr;
  std::string path_;
  std::string interface_name_;
  std::uint64_t lines_ = 0;
  std::uint64_t write_errors_ = 0;
};

}  // namespace teleop::transport
