#include "teleop/runtime/watchdog.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "teleop/error.hpp"

namespace teleop::runtime {

LinkWatchdog::LinkWatchdog(double timeout_s)
    : timeout_s_(timeout_s), last_feed_s_(std::numeric_limits<double>::quiet_NaN()) {
  if (!std::isfinite(timeout_s) || timeout_s <= 0.0) {
    throw Error("link watchdog: timeout " + std::to_string(timeout_s) + " s must be finite and > 0");
  }
}

void LinkWatchdog::Feed(double now_s) noexcept {
  if (!std::isfinite(now_s)) {
    ++rejected_times_;
    return;
  }
  ++feeds_;
  last_feed_s_ = now_s;
  if (state_ == State::kExpired) ++recoveries_;
  state_ = State::kValid;
}

bool LinkWatchdog::Fresh(double now_s) noexcept {
  if (state_ == State::kWaiting) return false;
  // Written so that NaN (now or last) fails the comparison and reads as expired.
  const bool fresh = now_s - last_feed_s_ <= timeout_s_;
  if (!fresh && state_ == State::kValid) {
    state_ = State::kExpired;
    ++trips_;
  }
  return fresh && state_ == State::kValid;
}

double LinkWatchdog::AgeS(double now_s) const noexcept {
  if (state_ == State::kWaiting) return std::numeric_limits<double>::infinity();
  return now_s - last_feed_s_;
}

void LinkWatchdog::Reset() noexcept {
  state_ = State::kWaiting;
  last_feed_s_ = std::numeric_limits<double>::quiet_NaN();
}

}  // namespace teleop::runtime
