#pragma once

#include <cstdint>

namespace teleop::runtime {

/// Link watchdog: the peer is valid while the newest fresh sample is at most `timeout_s` old. Fed with the time a
/// fresh sample arrived, asked with the current time (both on the loop's clock, s). Counts trips (valid → expired,
/// as observed by Fresh()) and recoveries (expired → valid, on the next Feed()). The first sample ever is neither.
/// All calls are noexcept and allocation-free.
class LinkWatchdog {
 public:
  enum class State : std::uint8_t {
    kWaiting,  ///< No sample yet: not valid, not a fault either.
    kValid,    ///< A sample arrived within the timeout.
    kExpired,  ///< The timeout passed since the newest sample (tripped).
  };

  /// `timeout_s` must be finite and > 0; throws teleop::Error otherwise (set-up).
  explicit LinkWatchdog(double timeout_s);

  /// A fresh sample arrived at `now_s`. A non-finite time is ignored (and counted).
  void Feed(double now_s) noexcept;
  /// True when the newest sample is at most timeout_s old at `now_s` (age == timeout is still fresh). Updates the
  /// state and counts a trip when it expires. A non-finite `now_s` counts as expired (the safe answer).
  [[nodiscard]] bool Fresh(double now_s) noexcept;

  State state() const noexcept { return state_; }
  bool peer_valid() const noexcept { return state_ == State::kValid; }
  bool expired() const noexcept { return state_ == State::kExpired; }
  double timeout_s() const noexcept { return timeout_s_; }
  /// Time of the newest sample (s); NaN before the first one.
  double last_feed_s() const noexcept { return last_feed_s_; }
  /// Age of the newest sample at `now_s` (s); +inf before the first one.
  double AgeS(double now_s) const noexcept;
  std::uint64_t feeds() const noexcept { return feeds_; }
  std::uint64_t trips() const noexcept { return trips_; }
  std::uint64_t recoveries() const noexcept { return recoveries_; }
  std::uint64_t rejected_times() const noexcept { return rejected_times_; }
  /// Back to kWaiting; the counters are kept.
  void Reset() noexcept;

 private:
  double timeout_s_;
  double last_feed_s_;
  State state_ = State::kWaiting;
  std::uint64_t feeds_ = 0;
  std::uint64_t trips_ = 0;
  std::uint64_t recoveries_ = 0;
  std::uint64_t rejected_times_ = 0;
};

}  // namespace teleop::runtime
