#pragma once

#include <array>
#include <cstdint>

namespace teleop::proto {

/// Version of the wire format. A receiver rejects any other version (counted as kBadVersion).
inline constexpr std::uint8_t kProtocolVersion = 1;
/// The most DOF one sample carries.
inline constexpr int kMaxWireDof = 6;

/// Who sent a message.
enum class SenderRole : std::uint8_t { kMaster = 0, kSlave = 1 };

/// State flags carried by every sample (bit set).
enum StateFlags : std::uint8_t {
  kFlagNone = 0,
  kFlagEnabled = 1u << 0,        ///< Sender's control loop is running and its actuator is enabled.
  kFlagFault = 1u << 1,          ///< Sender is in its safe state after a fault.
  kFlagPeerLost = 1u << 2,       ///< Sender's watchdog has no fresh sample from us.
  kFlagSaturated = 1u << 3,      ///< Sender's actuator hit its force limit this cycle.
  kFlagInFixture = 1u << 4,      ///< Sender is inside its forbidden region.
  kFlagShutdown = 1u << 5,       ///< Sender is stopping cleanly; the peer should go safe without a fault.
};

/// One cycle's state of one side, as exchanged at the loop rate. SI units, sender's base frame.
/// The master sends its handle position/velocity and the operator force it measures; the slave sends its tool
/// position/velocity and the environment force F_e it measures.
struct SampleMessage {
  SenderRole sender = SenderRole::kMaster;
  std::uint8_t flags = kFlagNone;
  std::uint8_t dof = 1;                 ///< 1..kMaxWireDof; entries past dof are not sent.
  std::uint32_t sequence = 0;           ///< +1 per cycle, wraps at 2^32.
  std::uint64_t sender_time_ns = 0;     ///< Sender's monotonic clock when the sample was taken.
  std::uint64_t echo_time_ns = 0;       ///< The newest peer sender_time_ns the sender had received (0: none yet).
  std::uint32_t echo_age_ns = 0;        ///< How long the sender held that echo before sending (for RTT).
  std::array<double, kMaxWireDof> position_m{};
  std::array<double, kMaxWireDof> velocity_m_per_s{};
  std::array<double, kMaxWireDof> force_N{};
};

}  // namespace teleop::proto
