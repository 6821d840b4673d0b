#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>

#include "teleop/runtime/cycle_trigger.hpp"
#include "teleop/runtime/latency_histogram.hpp"

namespace teleop::runtime {

struct PeriodicLoopConfig {
  double rate_hz = 1000.0;   ///< Accepted 250..8000 Hz (config validation); the loop itself takes 1..100000 Hz.
  int fifo_priority = 0;     ///< 0: normal scheduling; 1..99: SCHED_FIFO at this priority (needs root/CAP_SYS_NICE).
  int cpu = -1;              ///< -1: any CPU; else pin the loop thread to this CPU.
  bool lock_memory = false;  ///< mlockall(MCL_CURRENT | MCL_FUTURE) before the first cycle.
  double duration_s = 0.0;   ///< 0: run until Stop(); else stop after this much wall time.
  /// ≥ 0: for the whole of Run(), hold `cpu_dma_latency_path` open with this value (µs) written, so the CPUs do not
  /// enter idle states deeper than that (the PM QoS interface cyclictest uses; 0 = no idle halt). A failure to open
  /// or write it is a warning counted in CycleStats, not an error. -1: leave it alone.
  int cpu_dma_latency_us = -1;
  std::string cpu_dma_latency_path = "/dev/cpu_dma_latency";  ///< Injectable for tests.
  /// How cycles start: on the loop's own clock (kFree), or when the body's trigger fires (kTriggered, see
  /// PeriodicLoop::SetTrigger; without a trigger the loop runs free).
  CycleSync sync = CycleSync::kFree;
  /// Triggered mode: how long past the expected arrival the loop waits for the trigger before it runs the cycle
  /// anyway (a counted timeout). ≤ 0: a quarter of the period.
  std::int64_t trigger_timeout_margin_ns = 0;
  /// Triggered mode: > 0: from this long before the expected arrival, poll the trigger in a busy loop instead of
  /// sleeping in it, so the cycle starts without a wake-up latency (costs that much CPU per cycle). 0: off.
  std::int64_t trigger_spin_ns = 0;
  /// ≥ 1: the loop thread's timer slack (prctl PR_SET_TIMERSLACK, ns) for the whole of Run(): how late the kernel
  /// may let the loop's sleeps (clock_nanosleep, the trigger's ppoll) expire to batch wake-ups. The kernel's default
  /// for a normal-scheduled thread is 50 µs, which lands whole in the wake-up jitter; SCHED_FIFO threads get 0
  /// regardless. Default 1 (the least the kernel takes). 0: leave the inherited value (an A/B in teleop-loop-bench).
  std::int64_t timer_slack_ns = 1;
};

/// Per-cycle timing statistics, collected without allocation.
struct CycleStats {
  std::uint64_t cycles = 0;  ///< Cycles whose body ran.
  /// Deadline misses: cycles whose compute time exceeded the period, plus every slot skipped after a long overrun.
  std::uint64_t overruns = 0;
  std::uint64_t skipped_slots = 0;  ///< Slots dropped because the loop was more than a whole period late.
  LatencyHistogram period_ns;       ///< Measured wake-to-wake period (from the second cycle on).
  LatencyHistogram jitter_ns;       ///< Wake time - scheduled time (never negative with an absolute sleep).
  LatencyHistogram compute_ns;      ///< Time spent in the cycle body.
  /// True when the run had the real-time settings: SCHED_FIFO (fifo_priority > 0), locked memory, and the
  /// cpu_dma_latency request held; false means "running without real-time settings" (for the summary).
  bool realtime_settings_applied = false;
  bool cpu_dma_latency_held = false;   ///< The cpu_dma_latency_us request is held open for this run.
  int cpu_dma_latency_errno = 0;       ///< Why it is not (errno of the failed open/write), 0 when held or not asked.
  std::uint64_t setting_warnings = 0;  ///< Settings asked for but not applied (cpu_dma_latency, timer slack).
  std::int64_t timer_slack_ns = -1;  ///< The loop thread's timer slack during the run (PR_GET_TIMERSLACK), -1 unknown.
  std::uint64_t triggered_cycles = 0;  ///< Triggered mode: cycles started by the trigger.
  std::uint64_t trigger_timeouts = 0;  ///< Triggered mode: cycles started by the timeout (free-running fallback).
};

/// Monotonic clock (CLOCK_MONOTONIC) in ns: the loop's time base. Real-time safe.
std::int64_t MonotonicNowNs() noexcept;

/// An absolute-time periodic loop on CLOCK_MONOTONIC with clock_nanosleep(TIMER_ABSTIME): the schedule does not
/// drift with the compute time. Runs the body on the calling thread.
///
/// Slot k is scheduled at start + k·period. A cycle that ends late runs the next one at once (one catch-up cycle,
/// visible in the jitter); when the loop is a whole period or more behind, the slots that are entirely in the past
/// are skipped and counted (overruns, skipped_slots) instead of being run in a burst.
class PeriodicLoop {
 public:
  /// The cycle body: gets the index of this cycle (0, 1, 2, ... consecutive; skipped slots do not consume an
  /// index) and the nominal period. Must be noexcept and real-time safe. May call Stop().
  using Body = std::function<void(std::uint64_t cycle, double period_s)>;
  /// Waits until the trigger fires (true) or CLOCK_MONOTONIC reaches `deadline_ns` (false); returns early (false)
  /// when a signal interrupts it. Real-time safe: called from the loop thread between cycles.
  using WaitForTrigger = std::function<bool(std::int64_t deadline_ns)>;

  /// Validates the config (rate finite in 1..100000 Hz, fifo_priority 0..99, cpu ≥ -1, duration finite ≥ 0);
  /// throws teleop::Error otherwise. Touches no OS setting.
  explicit PeriodicLoop(const PeriodicLoopConfig& config);

  /// Applies the scheduling settings to the calling thread (affinity, SCHED_FIFO priority, mlockall; they stay
  /// applied after Run returns); throws teleop::Error with the OS reason and a hint when the OS refuses. Opens and
  /// holds the cpu_dma_latency request until Run returns (a failure is counted, see CycleStats). Then resets the
  /// timing statistics and runs until Stop() or the duration elapses. A loop stopped before Run() does not run.
  void Run(const Body& body);
  /// Applies the scheduling settings to the calling thread now and checks that they hold (the scheduling policy
  /// and priority, the CPU affinity read back); throws teleop::Error as Run() would. Run() on the same thread then
  /// does not apply them again. For a lifecycle that must know before a device is activated (TeleopNode::Activate).
  void ApplyRealtimeSettings();
  /// Phase-locked cycles (config sync = kTriggered; before Run()): instead of sleeping to its own schedule, the
  /// loop waits on `wait` (e.g. the link socket's readiness) with the deadline of a TriggerSchedule (expected
  /// arrival + timeout margin; never less than half a period between cycle starts), then runs the cycle. A timeout
  /// runs the cycle anyway and is counted. Jitter is then the distance from the expected start (see
  /// TriggerSchedule::CycleStarted); no slots are skipped. Ignored when config sync is kFree.
  void SetTrigger(WaitForTrigger wait) { trigger_ = std::move(wait); }
  /// True while the current cycle (read from the body) was started by the trigger rather than the clock.
  bool cycle_triggered() const noexcept { return cycle_triggered_; }
  /// Whether Run() waits on a trigger.
  bool triggered_mode() const noexcept { return config_.sync == CycleSync::kTriggered && trigger_ != nullptr; }

  /// Thread- and async-signal-safe. Takes effect before the next cycle (a pending sleep is cut short by a signal).
  void Stop() noexcept { stop_.store(true, std::memory_order_relaxed); }
  bool stopping() const noexcept { return stop_.load(std::memory_order_relaxed); }

  /// Read from the body (same thread) or after Run() returned: not synchronised with other threads.
  const CycleStats& stats() const noexcept { return stats_; }
  double period_s() const noexcept { return period_s_; }
  std::int64_t period_ns() const noexcept { return period_ns_; }

 private:
  void ApplySchedulingSettings() const;
  void RunFree(const Body& body, std::int64_t start, std::int64_t end);
  void RunTriggered(const Body& body, std::int64_t start, std::int64_t end);
  bool WaitForTheTrigger(std::int64_t expected_ns, std::int64_t deadline_ns);

  PeriodicLoopConfig config_;
  bool settings_applied_ = false;  ///< ApplyRealtimeSettings() ran (on the thread that will call Run()).
  double period_s_;
  std::int64_t period_ns_;
  CycleStats stats_{};
  WaitForTrigger trigger_;
  bool cycle_triggered_ = false;
  std::atomic<bool> stop_{false};
  static_assert(std::atomic<bool>::is_always_lock_free, "Stop() must be async-signal-safe");
};

}  // namespace teleop::runtime
