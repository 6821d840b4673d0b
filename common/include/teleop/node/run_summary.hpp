#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "teleop/runtime/latency_histogram.hpp"
#include "teleop/transport/link.hpp"
#include "teleop/types.hpp"

namespace teleop::node {

/// Percentiles of a distribution, in the unit the field name says.
struct Distribution {
  std::uint64_t count = 0;
  double p50 = 0.0;
  double p99 = 0.0;
  double max = 0.0;
};

/// What a process prints at the end of a run and writes with --summary-json. The field names are the JSON keys.
struct RunSummary {
  Role role = Role::kMaster;
  double rate_hz = 0.0;     ///< Configured.
  double duration_s = 0.0;  ///< Wall time from first to last cycle.
  std::uint64_t cycles = 0;
  double achieved_rate_hz = 0.0;  ///< cycles / duration.
  std::uint64_t overruns = 0;
  Distribution period_us{};   ///< Wake-to-wake period.
  Distribution jitter_us{};   ///< |wake - scheduled|.
  Distribution compute_us{};  ///< Cycle body time.
  transport::LinkCounters link{};
  std::string link_detail;              ///< Medium-specific counters (CAN frames by status, bus load); may be empty.
  std::uint64_t link_fault_cycles = 0;  ///< Cycles in which the medium itself was down (CAN bus-off).
  Distribution rtt_ms{};  ///< Network round trip: send call to the peer's kernel receive and back, hold time removed.
  // Phase-locking and data age (docs/performance.md).
  std::string sync = "free";           ///< Config sync.mode: "free" or "triggered".
  std::uint64_t triggered_cycles = 0;  ///< Cycles started by the peer's sample (a triggered slave).
  std::uint64_t trigger_timeouts = 0;  ///< Cycles started by the timeout instead (free-running fallback).
  /// Of those, the cycles in which the peer was fresh (the rest ran before the peer came or after it went).
  std::uint64_t trigger_timeouts_coupled = 0;
  Distribution data_age_us{};         ///< Age of the peer sample the law used: law start − its receive time.
  Distribution data_age_sender_us{};  ///< The same from the peer's send call (clock offset from the round trip).
  /// Cycles that used the peer's sample by its age in cycles: 0 (this cycle was triggered by it), 1, 2, 3 or more.
  std::array<std::uint64_t, 4> data_age_cycles{};
  bool realtime_settings_applied = false;  ///< SCHED_FIFO, locked memory (and cpu_dma_latency when asked) held.
  bool cpu_dma_latency_held = false;
  std::uint64_t cycles_with_peer = 0;  ///< Cycles in which the peer's sample was fresh (watchdog ok).
  std::uint64_t watchdog_trips = 0;
  std::uint64_t dof_mismatches = 0;  ///< Valid samples whose DOF count differs from ours: never applied.
  std::uint64_t device_fault_cycles = 0;
  std::uint64_t nonfinite_inputs = 0;
  std::uint64_t saturated_cycles = 0;
  double tracking_error_rms_m = 0.0;  ///< |local - peer| in the local frame over cycles with a fresh peer.
  double tracking_error_max_m = 0.0;
  double fixture_max_penetration_m = 0.0;
  std::uint64_t telemetry_records = 0;
  std::uint64_t telemetry_dropped = 0;
  std::string stop_reason;  ///< "duration", "signal", "peer shutdown", ...
};

/// Fills a Distribution from a histogram of nanoseconds, scaled to the given unit (1e3 → µs, 1e6 → ms).
Distribution FromHistogram(const runtime::LatencyHistogram& histogram, double ns_per_unit) noexcept;

/// Multi-line human-readable summary.
std::string FormatSummaryText(const RunSummary& summary);
/// The same as one JSON object.
std::string FormatSummaryJson(const RunSummary& summary);

}  // namespace teleop::node
