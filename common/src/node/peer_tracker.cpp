#include "peer_tracker.hpp"

namespace teleop::node {

Outage Blocker(std::uint32_t local_faults, const PeerView& peer) noexcept {
  if (local_faults != device::kFaultNone) return Outage::kDeviceFault;
  if (peer.new_session) return Outage::kNewSession;
  if (!peer.have_peer) return Outage::kNoPeer;
  if (peer.link_faulted) return Outage::kLinkFault;
  if (!peer.fresh) return Outage::kPeerLost;
  if (peer.shutdown) return Outage::kPeerShutdown;
  if (peer.peer_fault) return Outage::kPeerFault;
  if (peer.latency_gate_closed) return Outage::kLatency;
  return Outage::kNone;
}

PeerTracker::PeerTracker(const Config& config, transport::Link& link, EventLog& events, const NodeClock& clock)
    : config_(config), link_(link), events_(events), clock_(clock), watchdog_(config.timeout_s) {}

std::int64_t PeerTracker::UsedAt(std::int64_t law_start_ns, bool used) noexcept {
  const std::int64_t age_ns = used ? data_age_.ReceiveAgeNs(law_start_ns) : -1;
  data_age_.OnCycle(law_start_ns, used);
  return age_ns;
}

PeerView PeerTracker::Step(std::uint64_t cycle, std::int64_t now_ns, double t_s, bool triggered) noexcept {
  PeerView view;
  const bool got = link_.Poll(state_.incoming);
  // A new authenticated session is a new peer: forget the old one (the watchdog waits for the session's first
  // sample, CiA 301), and couple again only through aligning.
  if (const std::uint64_t epoch = link_.session_epoch(); epoch != state_.session_epoch) {
    StartSession(epoch, cycle, view);
  }
  const bool was_shutdown = state_.peer_shutdown;
  if (got) {
    if (state_.incoming.dof != config_.dof) {
      // A peer configured for another DOF count: never applied; the watchdog expires and coupling stays off.
      ++state_.dof_mismatches;
    } else {
      Accept(cycle, now_ns, t_s, triggered);
    }
  }
  view.shutdown_started = state_.peer_shutdown && !was_shutdown;
  return View(cycle, t_s, view);
}

void PeerTracker::StartSession(std::uint64_t epoch, std::uint64_t cycle, PeerView& view) noexcept {
  state_.session_epoch = epoch;
  view.new_session = true;
  ++state_.new_sessions;
  watchdog_.Reset();
  state_.have_peer = false;
  state_.peer_was_valid = false;
  state_.peer_shutdown = false;
  state_.last_flags = 0;
  events_.Push({Event::Kind::kNewSession, cycle, static_cast<double>(epoch)});
}

void PeerTracker::Accept(std::uint64_t cycle, std::int64_t now_ns, double t_s, bool triggered) noexcept {
  State& s = state_;
  s.peer = s.incoming;
  // The medium's receive time (the kernel's timestamp on UDP) makes the round trip and the data age the network's
  // and the sample's, not the phase between two cycles; the cycle start where the link has none (and on a stepped
  // clock, whose time is not the kernel's).
  const std::int64_t received_ns = clock_.stepped ? 0 : link_.newest_receive_time_ns();
  s.peer_rx_ns = received_ns > 0 ? received_ns : now_ns;
  if (!s.have_peer) events_.Push({Event::Kind::kPeerConnected, cycle, 0.0});
  s.have_peer = true;
  watchdog_.Feed(t_s);
  MeasureRoundTrip(cycle);
  const std::int64_t sent_local_ns =
      s.have_offset ? static_cast<std::int64_t>(s.peer.sender_time_ns) - s.peer_clock_offset_ns : 0;
  data_age_.OnNewSample(s.peer_rx_ns, sent_local_ns, triggered);
  const bool shutdown = (s.peer.flags & proto::kFlagShutdown) != 0;
  if (shutdown && !s.peer_shutdown) events_.Push({Event::Kind::kPeerShutdown, cycle, 0.0});
  s.peer_shutdown = shutdown;
  if ((s.peer.flags & proto::kFlagFault) != 0 && (s.last_flags & proto::kFlagFault) == 0) {
    events_.Push({Event::Kind::kPeerFault, cycle, 0.0});
  }
  s.last_flags = s.peer.flags;
}

void PeerTracker::MeasureRoundTrip(std::uint64_t cycle) noexcept {
  State& s = state_;
  const proto::RoundTripEstimate rtt = proto::EstimateRoundTrip(s.peer, static_cast<std::uint64_t>(s.peer_rx_ns));
  if (!rtt.valid) return;
  rtt_ns_.Add(rtt.rtt_ns);
  s.last_rtt_s = static_cast<double>(rtt.rtt_ns) * 1e-9;
  s.peer_clock_offset_ns = rtt.offset_ns;
  s.have_offset = true;
  if (!s.have_best_offset || static_cast<std::int64_t>(rtt.rtt_ns) < s.best_rtt_ns) {
    s.have_best_offset = true;
    s.best_offset_ns = rtt.offset_ns;
    s.best_rtt_ns = static_cast<std::int64_t>(rtt.rtt_ns);
  }
  // Latency gate with 20 % hysteresis (engagement.max_rtt_ms; 0 = off).
  const double limit_s = config_.max_rtt_s;
  if (limit_s > 0.0 && !s.latency_gate_closed && s.last_rtt_s > limit_s) {
    s.latency_gate_closed = true;
    ++s.latency_gate_trips;
    events_.Push({Event::Kind::kLatencyGate, cycle, s.last_rtt_s * 1e3});
  } else if (s.latency_gate_closed && s.last_rtt_s < 0.8 * limit_s) {
    s.latency_gate_closed = false;
  }
}

PeerView PeerTracker::View(std::uint64_t cycle, double t_s, PeerView view) noexcept {
  State& s = state_;
  view.have_peer = s.have_peer;
  view.fresh = s.have_peer && watchdog_.Fresh(t_s);
  view.link_faulted = link_.faulted();  // e.g. CAN bus-off: decouple now, not after the watchdog timeout
  if (view.link_faulted) ++s.link_fault_cycles;
  view.shutdown = s.peer_shutdown;
  view.peer_fault = (s.peer.flags & proto::kFlagFault) != 0;
  view.latency_gate_closed = s.latency_gate_closed;
  view.usable = view.fresh && !view.link_faulted && !view.shutdown && !view.peer_fault;
  view.sample = &s.peer;
  view.rx_ns = s.peer_rx_ns;
  view.rtt_s = s.last_rtt_s;
  view.last_feed_s = watchdog_.last_feed_s();
  if (s.have_peer && s.peer_was_valid && !view.fresh) events_.Push({Event::Kind::kPeerLost, cycle, 0.0});
  if (s.have_peer && !s.peer_was_valid && view.fresh && cycle > 0 && watchdog_.trips() > 0) {
    events_.Push({Event::Kind::kPeerRecovered, cycle, 0.0});
  }
  s.peer_was_valid = view.fresh;
  return view;
}

}  // namespace teleop::node
