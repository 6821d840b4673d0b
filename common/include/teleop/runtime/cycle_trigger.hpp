#pragma once

#include <cstdint>

namespace teleop::runtime {

/// How a process's cycles are timed (config `sync.mode`, docs/configuration.md and docs/performance.md).
enum class CycleSync : std::uint8_t {
  kFree,       ///< Every process runs its own clock: peer data is up to a period old when the law uses it.
  kTriggered,  ///< The master is the clock; the slave's cycle starts when the master's sample arrives.
};

/// "free" / "triggered".
const char* ToString(CycleSync sync) noexcept;

/// The schedule of a triggered (phase-locked) loop, as pure arithmetic on the loop's clock so that it can be
/// tested with a fake clock. The loop asks it when to stop waiting for the peer's sample (deadline_ns()) and
/// tells it when a cycle started and why (CycleStarted()).
///
/// - The next sample is expected one period after the last one arrived. The loop waits for it until
///   expected + timeout margin; a sample that has not arrived by then is a timeout: the cycle runs anyway (free-running
///   fallback, counted), and the next sample is expected one period later, so a silent peer leaves the process
///   running at its nominal rate, offset by the margin.
/// - A cycle never starts less than `min_spacing_ns` after the previous one (earliest_start_ns()): a flood of
///   datagrams, or a peer configured at a higher rate, cannot run this process faster than 1 / min_spacing.
class TriggerSchedule {
 public:
  struct Config {
    std::int64_t period_ns = 1'000'000;
    std::int64_t timeout_margin_ns = 250'000;  ///< > 0: how long past the expected arrival the loop waits.
    std::int64_t min_spacing_ns = 500'000;     ///< ≥ 0: shortest interval between two cycle starts.
  };

  explicit TriggerSchedule(const Config& config) noexcept : config_(config) {}

  /// The loop starts at `now_ns`: the first sample is expected within a period, the first cycle may start at once.
  void Start(std::int64_t now_ns) noexcept;
  /// Wait for the trigger no later than this.
  std::int64_t deadline_ns() const noexcept { return expected_ns_ + config_.timeout_margin_ns; }
  /// Do not start the next cycle before this.
  std::int64_t earliest_start_ns() const noexcept { return last_start_ns_ + config_.min_spacing_ns; }
  /// When the next sample is expected.
  std::int64_t expected_ns() const noexcept { return expected_ns_; }

  /// A cycle starts at `now_ns`, `triggered` by the peer's sample or after a timeout. Returns how far the start
  /// is from where the schedule expected it (|now - expected| when triggered, now - deadline after a timeout): the
  /// loop's jitter figure in this mode.
  std::int64_t CycleStarted(std::int64_t now_ns, bool triggered) noexcept;

  std::uint64_t triggered() const noexcept { return triggered_; }
  std::uint64_t timeouts() const noexcept { return timeouts_; }
  const Config& config() const noexcept { return config_; }

 private:
  Config config_;
  std::int64_t expected_ns_ = 0;
  std::int64_t last_start_ns_ = 0;
  std::uint64_t triggered_ = 0;
  std::uint64_t timeouts_ = 0;
};

}  // namespace teleop::runtime
