#pragma once

#include <cstdint>

#include "teleop/node/engagement.hpp"
#include "teleop/node/event_log.hpp"
#include "teleop/node/fault_recorder.hpp"
#include "teleop/node/run_summary.hpp"
#include "teleop/runtime/telemetry.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::node {

/// What one cycle emits, as every sink sees it: the telemetry row plus the counters a row does not carry. Built
/// once per cycle by the recorder from the values the stages passed (docs/architecture.md, "The cycle").
struct CycleRecord {
  const runtime::TelemetryRecord* telemetry = nullptr;  ///< This cycle's row (never null).
  EngagementState engagement = EngagementState::kDisengaged;
  bool stopping = false;              ///< The loop is stopping.
  bool local_fault = false;           ///< Device fault, the node's reading checks, or a non-finite law input.
  bool peer_fault = false;            ///< The peer's newest sample carries the fault flag.
  bool have_peer = false;             ///< A sample of this session is held.
  bool peer_shutdown = false;         ///< The peer announced a clean stop.
  bool peer_fresh = false;            ///< Watchdog ok and the medium up.
  std::uint8_t clutch = 0;            ///< Clutch sources held (node ClutchSource bits; 0: not clutched).
  std::uint32_t device_faults = 0;    ///< device::FaultBits the backend reported.
  std::uint32_t device_warnings = 0;  ///< device::WarningBits the backend reported.
  std::uint64_t overruns = 0;
  std::uint64_t watchdog_trips = 0;
  const transport::LinkCounters* link = nullptr;  ///< The link's counters now (never null).
  double tracking_error_m = 0.0;  ///< |x - scale · x_peer| in the local frame; 0 without a usable peer.
};

/// Whatever watches the cycle: the telemetry CSV, the fault ring, the DDS bridge, ... The node knows sinks, not
/// what is behind them; a new output is one class. OnCycle and OnFault run in the real-time cycle: copy into a
/// preallocated ring and return (no allocation, lock, blocking I/O or logging). OnEvent runs on the event log's
/// thread. Finish and Publish run once after the loop, in the order the sinks were added.
class CycleSink {
 public:
  virtual ~CycleSink() = default;
  /// Every cycle (a sink decimates on its own: record.telemetry->cycle).
  virtual void OnCycle(const CycleRecord& record) noexcept = 0;
  /// A recorded fault started this cycle (teleop/node/engagement.hpp, IsRecordedFault).
  virtual void OnFault(const FaultRecorder::Info& /*info*/) noexcept {}
  /// Every event, after the event log wrote it (not the real-time thread; must not block for long).
  virtual void OnEvent(const Event& /*event*/) noexcept {}
  /// After the last cycle: stop, write what is pending, and add this sink's counts to the summary.
  virtual void Finish(RunSummary& /*summary*/) {}
  /// After every sink's Finish and the event log's last event: the summary is complete.
  virtual void Publish(const RunSummary& /*summary*/) {}
};

}  // namespace teleop::node
