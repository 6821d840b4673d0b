#pragma once

#include <cstdint>

namespace teleop::dds {

/// At most one log line per `interval_ns` for one kind of message that the domain or the network can repeat at will
/// (a fake pair, a client dropped): the first occurrence logs, the ones within the interval are counted, and the
/// next line says how many were suppressed. Not thread-safe: one per thread.
class LogLimiter {
 public:
  explicit LogLimiter(std::int64_t interval_ns) : interval_ns_(interval_ns) {}

  /// True when a line may be written now; `suppressed` is then how many were held back since the last one.
  bool Allow(std::int64_t now_ns, std::uint64_t& suppressed) {
    if (logged_once_ && now_ns - last_ns_ < interval_ns_) {
      ++held_;
      return false;
    }
    suppressed = held_;
    held_ = 0;
    last_ns_ = now_ns;
    logged_once_ = true;
    return true;
  }

 private:
  std::int64_t interval_ns_;
  std::int64_t last_ns_ = 0;
  std::uint64_t held_ = 0;
  bool logged_once_ = false;
};

}  // namespace teleop::dds
