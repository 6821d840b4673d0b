#pragma once

#include <atomic>
#include <cstdint>
#include <functional>

#include "teleop/runtime/latency_histogram.hpp"

namespace teleop::runtime {

struct PeriodicLoopConfig {
  double rate_hz = 1000.0;       ///< Accepted 250..4000 Hz (config validation).
  int fifo_priority = 0;         ///< 0: normal scheduling; 1..99: SCHED_FIFO at this priority (needs root/CAP_SYS_NICE).
  int cpu = -1;                  ///< -1: any CPU; else pin the loop thread to this CPU.
  bool lock_memory = false;      ///< mlockall(MCL_CURRENT | MCL_FUTURE) before the first cycle.
  double duration_s = 0.0;       ///< 0: run until Stop(); else stop after this much wall time.
};

/// Per-cycle timing statistics, collected without allocation.
struct CycleStats {
  std::uint64_t cycles = 0;
  std::uint64_t overruns = 0;            ///< Cycles whose compute time exceeded the period (deadline missed).
  LatencyHistogram period_ns;            ///< Measured wake-to-wake period.
  LatencyHistogram jitter_ns;            ///< |wake time - scheduled time|.
  LatencyHistogram compute_ns;           ///< Time spent in the cycle body.
};

/// An absolute-time periodic loop on CLOCK_MONOTONIC with clock_nanosleep(TIMER_ABSTIME): the schedule does not
/// drift with the compute time. Runs the body on the calling thread.
class PeriodicLoop {
 public:
  /// The cycle body: gets the cycle index and the nominal period. Must be noexcept and real-time safe.
  using Body = std::function<void(std::uint64_t cycle, double period_s)>;

  explicit PeriodicLoop(const PeriodicLoopConfig& config);

  /// Applies the scheduling settings (priority, affinity, mlockall); throws teleop::Error with the reason when the
  /// OS refuses. Then runs until Stop() or the duration elapses.
  void Run(const Body& body);
  /// Thread- and signal-safe.
  void Stop() noexcept { stop_.store(true, std::memory_order_relaxed); }
  bool stopping() const noexcept { return stop_.load(std::memory_order_relaxed); }

  const CycleStats& stats() const noexcept { return stats_; }
  double period_s() const noexcept { return period_s_; }

 private:
  PeriodicLoopConfig config_;
  double period_s_;
  CycleStats stats_{};
  std::atomic<bool> stop_{false};
};

}  // namespace teleop::runtime
