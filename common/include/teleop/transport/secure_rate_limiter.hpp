#pragma once

#include <algorithm>
#include <cstdint>

namespace teleop::transport {

/// Token bucket for inbound datagrams, consulted before any parsing or cryptography so that a flood costs the
/// receiver one comparison per datagram. `rate_per_s` tokens are added per second of `now_ns` (the caller's
/// monotonic clock: no clock is read here, so tests drive it), up to `burst`; a datagram takes one token.
/// A clock that goes backwards adds nothing. No allocation, no state beyond two numbers.
class SecureRateLimiter {
 public:
  SecureRateLimiter(double rate_per_s, double burst) noexcept
      : rate_per_ns_(std::max(rate_per_s, 0.0) * 1e-9), burst_(std::max(burst, 1.0)), tokens_(burst_) {}

  [[nodiscard]] bool TryTake(std::uint64_t now_ns) noexcept {
    if (!started_) {
      started_ = true;
      last_ns_ = now_ns;
    } else if (now_ns > last_ns_) {
      tokens_ = std::min(burst_, tokens_ + static_cast<double>(now_ns - last_ns_) * rate_per_ns_);
      last_ns_ = now_ns;
    }
    if (tokens_ < 1.0) return false;
    tokens_ -= 1.0;
    return true;
  }

 private:
  double rate_per_ns_;
  double burst_;
  double tokens_;
  bool started_ = false;
  std::uint64_t last_ns_ = 0;
};

}  // namespace teleop::transport
