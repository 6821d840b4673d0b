#pragma once

#include <array>
#include <cstdint>

namespace teleop::proto {

/// Version of the wire format. A receiver rejects any other version (counted as kBadVersion).
/// Any change of layout or meaning of a field bumps it (docs/protocol.md, "Version policy").
inline constexpr std::uint8_t kProtocolVersion = 1;
/// The most DOF one sample carries (the dof byte allows more; 12 is the framework's kMaxDof). Widening it from 6
/// to 12 changed no byte of a 1..6-DOF sample; a receiver built with 6 rejects 7..12 as kBadDof.
inline constexpr int kMaxWireDof = 12;

/// Message types carried in the header. Only samples exist in version 1.
enum class MessageType : std::uint8_t { kSample = 1 };

/// Who sent a message.
enum class SenderRole : std::uint8_t { kMaster = 0, kSlave = 1 };

/// "master" / "slave" / "invalid".
const char* ToString(SenderRole role) noexcept;

/// The role at the other end of the link.
constexpr SenderRole PeerOf(SenderRole role) noexcept {
  return role == SenderRole::kMaster ? SenderRole::kSlave : SenderRole::kMaster;
}

/// State flags carried by every sample (bit set).
enum StateFlags : std::uint8_t {
  kFlagNone = 0,
  kFlagEnabled = 1u << 0,    ///< Sender's control loop is running and its actuator is enabled.
  kFlagFault = 1u << 1,      ///< Sender is in its safe state after a fault.
  kFlagPeerLost = 1u << 2,   ///< Sender's watchdog has no fresh sample from us.
  kFlagSaturated = 1u << 3,  ///< Sender's actuator hit its force limit this cycle.
  kFlagInFixture = 1u << 4,  ///< Sender is inside its forbidden region.
  kFlagShutdown = 1u << 5,   ///< Sender is stopping cleanly; the peer should go safe without a fault.
  kFlagClutched = 1u << 6,   ///< Sender's clutch is pressed: the pair decouples and re-indexes on release.
};
/// Every flag bit version 1 defines; a sample with any other bit set is rejected (kOutOfRange).
inline constexpr std::uint8_t kKnownFlags = 0x7F;

/// Accepted ranges of the per-DOF values (docs/protocol.md, "Fields"). A translational DOF is in m, m/s, N; a
/// rotational one in rad, rad/s, N·m with the same numeric limits. Anything outside is rejected (kOutOfRange):
/// no device this framework drives reaches them, so such a value is a fault, not a measurement.
inline constexpr double kMaxAbsPosition_m = 10.0;
inline constexpr double kMaxAbsVelocity_m_per_s = 100.0;
inline constexpr double kMaxAbsForce_N = 10000.0;
/// Accepted range of the energy block's cumulative energies: 0..this (J). At 10 kW it takes a day to get there.
inline constexpr double kMaxEnergy_J = 1e9;

/// One cycle's state of one side, as exchanged at the loop rate. SI units, sender's base frame.
/// The master sends its handle position/velocity and the operator force it measures; the slave sends its tool
/// position/velocity and the environment force F_e it measures.
struct SampleMessage {
  SenderRole sender = SenderRole::kMaster;
  std::uint8_t flags = kFlagNone;
  std::uint8_t dof = 1;              ///< 1..kMaxWireDof; entries past dof are not sent.
  std::uint32_t sequence = 0;        ///< +1 per cycle, wraps at 2^32.
  std::uint64_t sender_time_ns = 0;  ///< Sender's monotonic clock right before the send call.
  std::uint64_t echo_time_ns = 0;    ///< The newest peer sender_time_ns the sender had received (0: none yet).
  std::uint32_t echo_age_ns = 0;     ///< How long the sender held that echo before sending (for RTT).
  std::array<double, kMaxWireDof> position_m{};
  std::array<double, kMaxWireDof> velocity_m_per_s{};
  std::array<double, kMaxWireDof> force_N{};
  /// The energy block (time-domain passivity, energy_exchange; docs/protocol.md "Energy block"): sent when true.
  /// Per DOF, the sender's port energies since its start (J, ≥ 0, non-decreasing): what its law absorbed from its
  /// device (E_in, the peer's credit) and delivered to it (E_out, for diagnostics).
  bool has_energy = false;
  std::array<double, kMaxWireDof> input_energy_J{};
  std::array<double, kMaxWireDof> output_energy_J{};
};

/// NTP-style round trip estimated from one received sample (docs/protocol.md, "Round-trip time").
struct RoundTripEstimate {
  bool valid = false;          ///< False when the sample carries no echo or the numbers are inconsistent.
  std::int64_t rtt_ns = 0;     ///< Network round trip, excluding the time the peer held the echo.
  std::int64_t offset_ns = 0;  ///< Peer clock minus local clock, assuming symmetric one-way delays.
};

/// `received` is a sample from the peer whose echo_time_ns is a sender_time_ns we sent earlier (our clock);
/// `local_receive_time_ns` is when we received it (our clock). Pure arithmetic, no state.
///   t1 = echo_time_ns (we sent)  t2 = t3 - echo_age_ns (peer received)  t3 = sender_time_ns (peer sent)
///   t4 = local_receive_time_ns   rtt = (t4 - t1) - (t3 - t2)           offset = ((t2 - t1) + (t3 - t4)) / 2
constexpr RoundTripEstimate EstimateRoundTrip(const SampleMessage& received,
                                              std::uint64_t local_receive_time_ns) noexcept {
  RoundTripEstimate estimate{};
  if (received.echo_time_ns == 0 || local_receive_time_ns < received.echo_time_ns) return estimate;
  const auto t1 = static_cast<std::int64_t>(received.echo_time_ns);
  const auto t3 = static_cast<std::int64_t>(received.sender_time_ns);
  const std::int64_t t2 = t3 - static_cast<std::int64_t>(received.echo_age_ns);
  const auto t4 = static_cast<std::int64_t>(local_receive_time_ns);
  const std::int64_t rtt = (t4 - t1) - static_cast<std::int64_t>(received.echo_age_ns);
  if (rtt < 0) return estimate;
  estimate.valid = true;
  estimate.rtt_ns = rtt;
  estimate.offset_ns = ((t2 - t1) + (t3 - t4)) / 2;
  return estimate;
}

}  // namespace teleop::proto
