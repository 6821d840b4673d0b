#pragma once

// Stage 5 of the cycle (docs/architecture.md, "The cycle"): this cycle's sample to the peer. Private to the node.

#include <cstdint>

#include "coupling.hpp"
#include "peer_tracker.hpp"
#include "teleop/link/link_config.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::node {

/// Fills the sample (state, flags, echo, energy block) and sends it. Allocation-free and noexcept in Send.
class Transmitter {
 public:
  struct State {
    proto::SampleMessage outgoing{};
    std::uint32_t sequence = 0;
  };

  Transmitter(Role role, int dof, transport::Link& link, const NodeClock& clock);

  /// Returns the flags sent (proto::StateFlags).
  std::uint8_t Send(const Sensed& sensed, const PeerView& peer, const Applied& applied, bool stopping) noexcept;
  /// The last sample: tells the peer this process is going, so it stops coupling without a watchdog fault.
  void SendShutdown() noexcept;

 private:
  transport::Link& link_;
  const NodeClock& clock_;
  State state_;
};

}  // namespace teleop::node
