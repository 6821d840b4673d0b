#include "teleop/runtime/cycle_trigger.hpp"

#include <algorithm>

namespace teleop::runtime {

const char* ToString(CycleSync sync) noexcept {
  switch (sync) {
    case CycleSync::kFree:
      return "free";
    case CycleSync::kTriggered:
      return "triggered";
  }
  return "invalid";
}

void TriggerSchedule::Start(std::int64_t now_ns) noexcept {
  expected_ns_ = now_ns + config_.period_ns;
  last_start_ns_ = now_ns - config_.min_spacing_ns;
  triggered_ = 0;
  timeouts_ = 0;
}

std::int64_t TriggerSchedule::CycleStarted(std::int64_t now_ns, bool triggered) noexcept {
  std::int64_t off_schedule = 0;
  if (triggered) {
    ++triggered_;
    off_schedule = now_ns >= expected_ns_ ? now_ns - expected_ns_ : expected_ns_ - now_ns;
    expected_ns_ = now_ns + config_.period_ns;
  } else {
    ++timeouts_;
    off_schedule = std::max<std::int64_t>(now_ns - deadline_ns(), 0);
    // Keep the peer's cadence on its grid: a wake-up that overshoots the deadline (the timer's latency, tens of µs
    // on a VM) must not push every later deadline by as much, or a silent peer's process runs at 1 / (T + overshoot).
    // Only when the next deadline would come sooner than the minimum spacing (a stall of about half a period or
    // more) does the grid restart from now: free-running at the nominal period, offset by the margin, no burst of
    // cycles to catch up.
    expected_ns_ += config_.period_ns;
    if (deadline_ns() < now_ns + config_.min_spacing_ns) {
      expected_ns_ = now_ns + config_.period_ns - config_.timeout_margin_ns;
    }
  }
  last_start_ns_ = now_ns;
  return off_schedule;
}

}  // namespace teleop::runtime
