#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "teleop/node/fault_recorder.hpp"
#include "teleop/runtime/latency_histogram.hpp"
#include "teleop/transport/impairment_model.hpp"
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

/// Coupling over the run (teleop/node/engagement.hpp).
struct EngagementSummary {
  std::string reaction;     ///< safety.reaction: what the process does while not coupled.
  std::string final_state;  ///< Engagement state at the end.
  std::uint64_t times_engaged = 0;
  std::uint64_t couplings_lost = 0;  ///< Aligning or engaged ended (an outage).
  std::uint64_t engaged_cycles = 0;
  double aligning_mean_s = 0.0;  ///< Aligning durations of the alignings that reached engaged.
  double aligning_max_s = 0.0;
  double max_reference_step_m = 0.0;  ///< Largest one-cycle jump of the coupling reference while (re)engaging.
  double max_aligning_force_rate_N_per_s = 0.0;  ///< Largest coupling-force rate while aligning and at engagement.
  std::uint64_t latency_gate_trips = 0;
  std::uint64_t new_sessions = 0;
  std::uint64_t encoder_jumps = 0;  ///< Readings refused by the node's checks (safety.*), each a device fault.
  std::uint64_t out_of_range_readings = 0;
  std::uint64_t nonfinite_readings = 0;
};

/// The device's warnings over the run (device::Reading::warnings, WarningBits; informational, the node acts on
/// none).
struct DeviceWarningSummary {
  std::uint64_t changes = 0;  ///< Cycles in which the warning word changed (each an event).
  std::uint64_t cycles = 0;   ///< Cycles with any warning bit set.
  std::uint32_t last = 0;     ///< The word at the end of the run.
  std::uint32_t seen = 0;     ///< Every bit seen during the run (OR).
};

/// What a process prints at the end of a run and writes with --summary-json. Both come from one table in
/// run_summary.cpp (kSummaryFields: per field its JSON key and value, and the text line that phrases it; mostly the
/// field names here): a new field is a member here, a row there, and the line of a Summarize* that fills it.
struct RunSummary {
  Role role = Role::kMaster;
  std::string software_version;  ///< teleop::SoftwareVersion() (git describe at build time).
  int protocol_version = 0;  ///< The wire protocol this process speaks (proto::kProtocolVersion; psk: the secure one).
  /// Whether a usable sample of the peer ever arrived; `connection` says why not (ConnectionWatch). A run that never
  /// connected exits kExitNeverConnected.
  bool connected = true;
  std::string connection = "connected";
  double rate_hz = 0.0;     ///< Configured.
  double duration_s = 0.0;  ///< Wall time from first to last cycle.
  std::uint64_t cycles = 0;
  double achieved_rate_hz = 0.0;  ///< cycles / duration.
  std::uint64_t overruns = 0;
  Distribution period_us{};   ///< Wake-to-wake period.
  Distribution jitter_us{};   ///< |wake - scheduled|.
  Distribution compute_us{};  ///< Cycle body time.
  transport::LinkCounters link{};
  std::string link_transport = "udp";      ///< link.transport: "udp", "can" or "emulated-can".
  std::string link_security = "insecure";  ///< link.security.mode: "psk" or "insecure" (counters in `link`).
  std::string link_detail;                 ///< Medium-specific counters (CAN frames by status, bus load); may be empty.
  std::uint64_t link_fault_cycles = 0;     ///< Cycles in which the medium itself was down (CAN bus-off).
  /// With `link.emulate`: what the emulated network did to the samples this process received (JSON null without).
  std::optional<transport::ImpairmentCounters> link_emulation;
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
  double tracking_error_rms_m = 0.0;  ///< |local - peer| in the local frame over the engaged cycles.
  double tracking_error_max_m = 0.0;
  double fixture_max_penetration_m = 0.0;
  std::uint64_t telemetry_records = 0;
  std::uint64_t telemetry_dropped = 0;
  std::string stop_reason;  ///< "duration", "signal", "peer shutdown", ...
  // Time-domain passivity (docs/stability.md).
  std::string passivity_mode = "off";               ///< "off" (observe only), "observer", "energy_exchange".
  std::uint64_t passivity_cycles = 0;               ///< Cycles in which the passivity controller acted.
  double passivity_dissipated_J = 0.0;              ///< Energy its damper dissipated, all DOF.
  double passivity_min_observed_J = 0.0;            ///< Minimum of the observed energy W (docs/stability.md).
  std::uint64_t passivity_peer_without_energy = 0;  ///< energy_exchange: peer samples without the energy block.
  EngagementSummary engagement{};
  DeviceWarningSummary device_warnings{};
  std::vector<FaultReport> faults;          ///< Every fault: what, when, the reaction, its record file.
  std::uint64_t fault_records_skipped = 0;  ///< Faults without a record (writer busy, safety.max_fault_records).
  // The session record (deploy/teleop-session merges both sides' summaries and telemetry on one clock).
  std::int64_t clock_start_monotonic_ns = 0;  ///< CLOCK_MONOTONIC of the first cycle: the telemetry's time_s 0.
  /// The peer's clock minus ours, from the round trip with the smallest round trip; its uncertainty is half that
  /// round trip. Empty without a round trip (CAN, or never connected).
  std::optional<std::int64_t> peer_clock_offset_ns;
  std::int64_t peer_clock_offset_uncertainty_ns = 0;
  std::string telemetry_csv;     ///< Path of the telemetry CSV (empty: none written).
  std::string config_path;       ///< The config file, absolute.
  std::string config_yaml;       ///< Its text as read at start-up.
  std::string startup_analysis;  ///< The start-up stability check's verdict line.
};

/// Fills a Distribution from a histogram of nanoseconds, scaled to the given unit (1e3 → µs, 1e6 → ms).
Distribution FromHistogram(const runtime::LatencyHistogram& histogram, double ns_per_unit) noexcept;

/// Multi-line human-readable summary.
std::string FormatSummaryText(const RunSummary& summary);
/// The same as one JSON object.
std::string FormatSummaryJson(const RunSummary& summary);

}  // namespace teleop::node
