#pragma once

// Stage 2 of the cycle (docs/architecture.md, "The cycle"): the peer as this process sees it. Private to the node.

#include <cstdint>
#include <limits>

#include "teleop/device/device.hpp"
#include "teleop/node/engagement.hpp"
#include "teleop/node/event_log.hpp"
#include "teleop/proto/sample_message.hpp"
#include "teleop/runtime/data_age.hpp"
#include "teleop/runtime/latency_histogram.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "teleop/runtime/watchdog.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::node {

/// The loop's clock, or the caller's in a stepped run (TeleopNode::Step with now_ns).
struct NodeClock {
  bool stepped = false;
  std::int64_t stepped_now_ns = 0;
  std::int64_t Now() const noexcept { return stepped ? stepped_now_ns : runtime::MonotonicNowNs(); }
};

/// What the peer tracker concluded about the peer this cycle (its output value).
struct PeerView {
  bool fresh = false;                            ///< A sample arrived within the watchdog timeout.
  bool link_faulted = false;                     ///< The link reports a fault (CAN bus-off, ...).
  bool usable = false;                           ///< Fresh, link fine, peer neither shutting down nor faulted: couple.
  bool new_session = false;                      ///< The link started a new session this cycle.
  bool have_peer = false;                        ///< A sample of this session is held (`sample` is valid).
  bool shutdown = false;                         ///< The newest sample carries the shutdown flag.
  bool shutdown_started = false;                 ///< ... and the one before did not (this cycle).
  bool peer_fault = false;                       ///< The newest sample carries the fault flag.
  bool latency_gate_closed = false;              ///< Round trip above engagement.max_rtt_ms (20 % hysteresis).
  const proto::SampleMessage* sample = nullptr;  ///< The newest accepted sample (never null).
  std::int64_t rx_ns = 0;                        ///< When the medium received it, loop clock.
  double rtt_s = std::numeric_limits<double>::quiet_NaN();        ///< Newest round trip; NaN before the first.
  double last_feed_s = std::numeric_limits<double>::quiet_NaN();  ///< Watchdog time of the newest sample.
};

/// Why coupling cannot run this cycle, in precedence order (teleop/node/engagement.hpp, Outage).
Outage Blocker(std::uint32_t local_faults, const PeerView& peer) noexcept;

/// Receive, watchdog, round trip, latency gate and data age: drains the link and keeps the newest sample of the
/// session. Allocation-free and noexcept in Step.
class PeerTracker {
 public:
  struct Config {
    int dof = 1;
    double timeout_s = 0.1;  ///< link.timeout_ms
    double max_rtt_s = 0.0;  ///< engagement.max_rtt_ms (0 = no latency gate)
  };
  /// Across cycles: what is known about the peer and the run's counts.
  struct State {
    proto::SampleMessage incoming{};
    proto::SampleMessage peer{};
    std::uint64_t session_epoch = 0;
    bool have_peer = false;
    bool peer_was_valid = false;
    bool peer_shutdown = false;
    bool latency_gate_closed = false;
    bool have_offset = false;
    std::uint8_t last_flags = 0;
    std::int64_t peer_rx_ns = 0;
    std::int64_t peer_clock_offset_ns = 0;  ///< Peer clock − ours, from the newest round trip.
    /// The offset from the round trip with the smallest round trip of the run (its uncertainty is half of it): what
    /// a session record uses to put both sides on one clock (deploy/teleop-session).
    bool have_best_offset = false;
    std::int64_t best_offset_ns = 0;
    std::int64_t best_rtt_ns = 0;
    double last_rtt_s = std::numeric_limits<double>::quiet_NaN();
    std::uint64_t new_sessions = 0;
    std::uint64_t dof_mismatches = 0;
    std::uint64_t link_fault_cycles = 0;
    std::uint64_t latency_gate_trips = 0;
  };

  /// `clock`: on a stepped clock the link's kernel stamps are not on the caller's time and are not used.
  PeerTracker(const Config& config, transport::Link& link, EventLog& events, const NodeClock& clock);

  /// `triggered`: this cycle was started by the peer's sample (phase-locked loop).
  PeerView Step(std::uint64_t cycle, std::int64_t now_ns, double t_s, bool triggered) noexcept;
  /// The law ran at `law_start_ns` with the newest sample (`used`: the peer was usable). Returns the sample's age
  /// then (ns), -1 when not used; the data age statistics count it.
  std::int64_t UsedAt(std::int64_t law_start_ns, bool used) noexcept;

  const State& state() const noexcept { return state_; }
  const runtime::LinkWatchdog& watchdog() const noexcept { return watchdog_; }
  const runtime::LatencyHistogram& rtt_ns() const noexcept { return rtt_ns_; }
  runtime::DataAgeTracker& data_age() noexcept { return data_age_; }
  const runtime::DataAgeTracker& data_age() const noexcept { return data_age_; }

 private:
  void StartSession(std::uint64_t epoch, std::uint64_t cycle, PeerView& view) noexcept;
  void Accept(std::uint64_t cycle, std::int64_t now_ns, double t_s, bool triggered) noexcept;
  void MeasureRoundTrip(std::uint64_t cycle) noexcept;
  PeerView View(std::uint64_t cycle, double t_s, PeerView view) noexcept;

  Config config_;
  transport::Link& link_;
  EventLog& events_;
  const NodeClock& clock_;
  runtime::LinkWatchdog watchdog_;
  runtime::LatencyHistogram rtt_ns_;
  runtime::DataAgeTracker data_age_;  ///< Age of the peer sample the law uses (docs/performance.md).
  State state_;
};

}  // namespace teleop::node
