#pragma once

#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "teleop/runtime/telemetry.hpp"
#include "teleop/transport/link.hpp"
#include "teleop/types.hpp"

namespace teleop::dds {

/// How many axes each array of the DDS State message holds (`position_m[6]` ... in teleop_msgs.idl; the bridge and
/// the supervisor check it against the generated type): one Cartesian device. Not a DOF limit -- the one DOF limit is
/// teleop::kMaxDof -- a pair of more DOF shows its first kStateAxes on DDS (docs/dds.md).
inline constexpr std::size_t kStateAxes = 6;
static_assert(kStateAxes <= static_cast<std::size_t>(kMaxDof), "a State array cannot be wider than a DOF vector");

/// Where a process stands with its peer, as the State message carries it (`engagement`, docs/dds.md).
enum class Engagement : std::uint8_t {
  kWaiting = 0,       ///< No sample from the peer yet.
  kCoupled = 1,       ///< Fresh peer, no fault: the law couples the two sides.
  kPeerLost = 2,      ///< The peer's samples stopped (watchdog) or the medium is down.
  kPeerShutdown = 3,  ///< The peer announced a clean stop.
  kFault = 4,         ///< This device or the peer reports a fault (or a non-finite input): safe state.
  kStopping = 5,      ///< This process is stopping.
  kAligning = 6,      ///< Fresh peer, no fault, but not yet engaged: the node is handshaking or aligning
                      ///< (docs/engagement.md); the law does not run eqs. 8/9 yet.
};

inline const char* ToString(Engagement e) noexcept {
  switch (e) {
    case Engagement::kWaiting:
      return "waiting";
    case Engagement::kCoupled:
      return "coupled";
    case Engagement::kPeerLost:
      return "peer_lost";
    case Engagement::kPeerShutdown:
      return "peer_shutdown";
    case Engagement::kFault:
      return "fault";
    case Engagement::kStopping:
      return "stopping";
    case Engagement::kAligning:
      return "aligning";
  }
  return "unknown";
}

/// What the loop knows about its coupling in one cycle, reduced to one Engagement. Precedence: stopping, fault,
/// no peer yet, peer shutdown, peer lost, aligning (fresh peer, the engagement machine not yet engaged), coupled.
struct EngagementInputs {
  bool stopping = false;
  bool local_fault = false;  ///< Device fault or non-finite law input this cycle.
  bool peer_fault = false;   ///< The peer's newest sample carries the fault flag.
  bool have_peer = false;    ///< At least one valid sample from the peer so far.
  bool peer_shutdown = false;
  bool peer_fresh = false;  ///< Watchdog ok and the medium up.
  bool engaged = true;      ///< The node's engagement machine is in kEngaged (false while handshaking/aligning).
};

constexpr Engagement EngagementOf(const EngagementInputs& in) noexcept {
  if (in.stopping) return Engagement::kStopping;
  if (in.local_fault || (in.have_peer && in.peer_fault && !in.peer_shutdown)) return Engagement::kFault;
  if (!in.have_peer) return Engagement::kWaiting;
  if (in.peer_shutdown) return Engagement::kPeerShutdown;
  if (!in.peer_fresh) return Engagement::kPeerLost;
  if (!in.engaged) return Engagement::kAligning;
  return Engagement::kCoupled;
}

/// One state record handed from the loop to the bridge (a copy through its lock-free ring, at dds.state_rate_hz):
/// the cycle's telemetry record plus the counters the CSV does not carry. The loop owns the counters, so it copies
/// them here; the bridge thread never reads the loop's memory.
struct BridgeSample {
  runtime::TelemetryRecord record{};
  Engagement engagement = Engagement::kWaiting;
  std::uint32_t device_faults = 0;
  std::uint64_t overruns = 0;
  std::uint64_t watchdog_trips = 0;
  transport::LinkCounters link{};
  double tracking_error_m = 0.0;  ///< |x - scale * x_peer| in the local frame; 0 without a fresh peer.
};
static_assert(std::is_trivially_copyable_v<BridgeSample>);

}  // namespace teleop::dds
