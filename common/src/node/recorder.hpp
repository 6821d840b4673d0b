#pragma once

// Stage 6 of the cycle (docs/architecture.md, "The cycle"): statistics, events and the cycle's record to every
// sink (telemetry CSV, fault ring, DDS). Private to the node.

#include <cstdint>
#include <limits>

#include "coupling.hpp"
#include "peer_tracker.hpp"
#include "sinks.hpp"
#include "teleop/config/process_config.hpp"
#include "teleop/node/event_log.hpp"
#include "teleop/runtime/telemetry.hpp"

namespace teleop::node {

/// What the loop knows about this cycle besides the stages' values.
struct CycleFacts {
  std::uint64_t cycle = 0;
  double t_s = 0.0;
  std::uint8_t flags = 0;         ///< Sent this cycle (Transmitter).
  std::int64_t data_age_ns = -1;  ///< Age of the peer sample the law used; -1: none.
  double fixture_limit_N_per_m =
      std::numeric_limits<double>::quiet_NaN();  ///< TeleopNode::SetFixtureLimit's newest value (NaN: none).
  std::int64_t cycle_start_mono_ns = 0;
  bool stopping = false;
  bool coupled_trigger_timeout = false;  ///< A triggered cycle that timed out while the peer was usable.
  std::uint64_t overruns = 0;
  std::uint64_t watchdog_trips = 0;
  const transport::LinkCounters* link = nullptr;
};

/// Run statistics, the events they raise, and every sink. Allocation-free and noexcept in Step.
class Recorder {
 public:
  struct Config {
    int dof = 1;
    int joints = 0;  ///< device::Capabilities::joints: the joint readings recorded (0: none).
    double peer_position_scale = 1.0;
    std::uint64_t rate = 1000;  ///< Cycles per second, for rate-limiting events.
  };
  /// The run's statistics (the summary reads them) and what crosses cycles.
  struct State {
    std::uint64_t cycles_with_peer = 0;
    std::uint64_t engaged_cycles = 0;
    std::uint64_t device_fault_cycles = 0;
    std::uint64_t saturated_cycles = 0;
    std::uint64_t nonfinite_inputs = 0;
    std::uint64_t coupled_trigger_timeouts = 0;  ///< Triggered cycles that timed out while the peer was fresh.
    std::uint64_t reported_overruns = 0;
    std::uint64_t overrun_event_cycle = 0;
    double tracking_sq_sum = 0.0;
    double tracking_max = 0.0;
    double max_penetration = 0.0;
    bool device_faulted = false;               ///< Last cycle had a device fault (for its events).
    std::uint32_t active_faults = 0;           ///< Bit(Outage) of the recorded faults present last cycle.
    std::uint32_t device_warnings = 0;         ///< device::WarningBits of the last cycle.
    std::uint64_t device_warning_changes = 0;  ///< Cycles in which the warning word changed.
    std::uint64_t device_warning_cycles = 0;   ///< Cycles with any warning bit set.
    std::uint32_t device_warnings_seen = 0;    ///< Every warning bit seen in the run.
  };

  Recorder(const Config& config, SinkSet& sinks, EventLog& events);

  void Step(const Sensed& sensed, const PeerView& peer, const Applied& applied, const CycleFacts& facts) noexcept;

  const State& state() const noexcept { return state_; }

 private:
  void Count(const Sensed& sensed, const PeerView& peer, const Applied& applied, const CycleFacts& facts) noexcept;
  void RaiseEvents(const Sensed& sensed, const Applied& applied, const CycleFacts& facts) noexcept;
  const runtime::TelemetryRecord& Row(const Sensed& sensed, const PeerView& peer, const Applied& applied,
                                      const CycleFacts& facts) noexcept;
  void TriggerFaults(const Sensed& sensed, const PeerView& peer, const Applied& applied,
                     const CycleFacts& facts) noexcept;

  Config config_;
  SinkSet& sinks_;
  EventLog& events_;
  State state_;
  runtime::TelemetryRecord row_{};
};

}  // namespace teleop::node
