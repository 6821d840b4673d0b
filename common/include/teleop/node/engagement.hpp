#pragma once

#include <cstdint>

#include "teleop/node/engagement_config.hpp"
#include "teleop/types.hpp"

namespace teleop::node {

/// Where a process is in coupling to its peer. The numbers are the telemetry column `engagement`.
enum class EngagementState : std::uint8_t {
  kDisengaged = 0,   ///< Something local prevents coupling (device fault, non-finite input); safe state.
  kHandshaking = 1,  ///< Waiting for the first accepted sample of a session, or of the peer after an outage.
  kAligning = 2,     ///< Peer usable; the coupling reference moves to the peer at bounded speed (Aligner).
  kEngaged = 3,      ///< Coupled: the law's eqs. 8/9 with the peer's sample.
};
const char* ToString(EngagementState state) noexcept;

/// Why coupling cannot run this cycle (kNone: it can). In precedence order after kNone: the node reports the first
/// that applies.
enum class Outage : std::uint8_t {
  kNone = 0,
  kDeviceFault,     ///< Device fault bits, or the node's plausibility checks of the reading (local).
  kNonFiniteInput,  ///< The law saw NaN/inf (local).
  kNoPeer,          ///< No sample yet (start-up or a new session): waiting, not a fault.
  kLinkFault,       ///< The medium is down (CAN bus-off).
  kPeerLost,        ///< Watchdog: no fresh sample within link.timeout_ms.
  kPeerShutdown,    ///< The peer said it is stopping.
  kPeerFault,       ///< The peer's sample carries the fault flag.
  kNewSession,      ///< The link started a new authenticated session (Link::session_epoch changed).
  kLatency,         ///< Latency gate: round trip above engagement.max_rtt_ms.
  kClutch,          ///< This process's clutch, or the peer's (its sample's kFlagClutched), is pressed.
  kCount,
};
const char* ToString(Outage outage) noexcept;
/// A local outage keeps the process disengaged (device safe state); the others leave it handshaking.
constexpr bool IsLocal(Outage o) noexcept { return o == Outage::kDeviceFault || o == Outage::kNonFiniteInput; }
/// Outages that write a fault record (the last N cycles) when they start.
constexpr bool IsRecordedFault(Outage o) noexcept {
  return o == Outage::kDeviceFault || o == Outage::kNonFiniteInput || o == Outage::kLinkFault ||
         o == Outage::kPeerLost || o == Outage::kLatency;
}

/// disengaged → handshaking → aligning → engaged. Coupling starts, and restarts after any outage, only through
/// aligning. Allocation-free, noexcept; time on the loop's clock (s).
class EngagementMachine {
 public:
  struct Transition {
    bool coupling_lost = false;     ///< Left aligning/engaged this cycle (the reaction is latched now).
    bool aligning_started = false;  ///< Entered aligning this cycle (the Aligner starts now).
    bool engaged = false;           ///< Entered engaged this cycle.
  };

  /// One cycle. `blocker`: why coupling cannot run (kNone: the peer is usable and nothing local is wrong);
  /// `aligned`: the Aligner's verdict for this cycle (read only while aligning).
  Transition Update(Outage blocker, bool aligned, double t_s) noexcept;

  EngagementState state() const noexcept { return state_; }
  /// True in aligning and engaged: the law runs with the (aligned) peer.
  bool coupling() const noexcept { return state_ == EngagementState::kAligning || state_ == EngagementState::kEngaged; }
  /// The blocker of the most recent cycle that had one.
  Outage last_outage() const noexcept { return last_outage_; }
  std::uint64_t engagements() const noexcept { return engagements_; }        ///< Times engaged.
  std::uint64_t couplings_lost() const noexcept { return couplings_lost_; }  ///< Times aligning/engaged ended.
  std::uint64_t alignings() const noexcept { return alignings_completed_; }  ///< Alignings that reached engaged.
  double aligning_max_s() const noexcept { return aligning_max_s_; }
  double aligning_mean_s() const noexcept {
    return alignings_completed_ > 0 ? aligning_sum_s_ / static_cast<double>(alignings_completed_) : 0.0;
  }

 private:
  EngagementState state_ = EngagementState::kDisengaged;
  Outage last_outage_ = Outage::kNoPeer;
  double aligning_since_s_ = 0.0;
  std::uint64_t engagements_ = 0;
  std::uint64_t couplings_lost_ = 0;
  std::uint64_t alignings_completed_ = 0;
  double aligning_sum_s_ = 0.0;
  double aligning_max_s_ = 0.0;
};

/// Aligning: a coupling reference in the local frame that starts at the local position and moves to the peer's
/// position at most align_speed_m_per_s, then follows it; the K_f force ramps in over align_min_time_ms. Aligned
/// once the reference is within align_tolerance_m of the peer on every axis after align_min_time_ms.
/// Allocation-free after construction.
class Aligner {
 public:
  Aligner(const EngagementConfig& config, int dof);

  void Start(const DofVector& local_position_m, double t_s) noexcept;
  /// One cycle: moves the reference toward `peer_position_m` (local frame). Returns the reference.
  const DofVector& Step(const DofVector& peer_position_m, double t_s, double period_s) noexcept;

  const DofVector& reference_m() const noexcept { return reference_m_; }
  /// The reference's velocity over the last Step (m/s).
  const DofVector& reference_velocity_m_per_s() const noexcept { return velocity_m_per_s_; }
  /// Largest |Δreference| on an axis in the last Step (m).
  double last_step_m() const noexcept { return last_step_m_; }
  /// 0 → 1 over align_min_time_ms since Start.
  double ramp() const noexcept { return ramp_; }
  /// The reference reached the peer and the minimum time has passed.
  bool aligned() const noexcept { return aligned_; }
  /// The reference is within align_tolerance_m of the peer on every axis (it follows the peer from now on).
  bool caught_up() const noexcept { return caught_up_; }

 private:
  EngagementConfig config_;
  DofVector reference_m_;
  DofVector velocity_m_per_s_;
  double start_s_ = 0.0;
  double last_step_m_ = 0.0;
  double ramp_ = 0.0;
  bool aligned_ = false;
  bool caught_up_ = false;
};

/// Bounds the rate of change of a per-axis force (N/s). Allocation-free after construction.
class ForceRateLimiter {
 public:
  explicit ForceRateLimiter(int dof) : last_N_(DofVector::Zero(dof)) {}
  /// Returns `desired` moved from the last output by at most rate·period per axis; remembers it. `clipped()`
  /// tells whether any axis was limited.
  const DofVector& Limit(const DofVector& desired_N, double max_rate_N_per_s, double period_s) noexcept;
  /// Sets the last output without limiting (the force actually applied this cycle by another path).
  void Track(const DofVector& applied_N) noexcept {
    last_N_ = applied_N;
    clipped_ = false;
  }
  const DofVector& last_N() const noexcept { return last_N_; }
  bool clipped() const noexcept { return clipped_; }

 private:
  DofVector last_N_;
  bool clipped_ = false;
};

}  // namespace teleop::node
