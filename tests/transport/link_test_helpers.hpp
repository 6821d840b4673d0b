#pragma once

#include <cstdint>
#include <numeric>

#include "teleop/proto/sample_message.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::transport::test {

/// A valid sample from `sender` with recognisable values derived from `sequence`.
inline proto::SampleMessage MakeSample(proto::SenderRole sender, std::uint32_t sequence, int dof = 3) {
  proto::SampleMessage m;
  m.sender = sender;
  m.flags = proto::kFlagEnabled;
  m.dof = static_cast<std::uint8_t>(dof);
  m.sequence = sequence;
  m.sender_time_ns = 1'000'000ull * sequence;
  for (int i = 0; i < dof; ++i) {
    m.position_m[i] = 0.001 * (sequence % 1000) + 0.1 * i;  // stays inside the ±10 m wire range
    m.velocity_m_per_s[i] = -0.01 * i;
    m.force_N[i] = 1.0 + i;
  }
  return m;
}

/// Every datagram read ends up under exactly one outcome, and rejected is split into its reasons.
inline void ExpectCountersBalance(const LinkCounters& c) {
  EXPECT_EQ(c.received, c.accepted + c.superseded + c.reordered + c.duplicates + c.rejected + c.handshake_messages);
  const std::uint64_t by_reason =
      std::accumulate(c.rejected_by_reason.begin(), c.rejected_by_reason.end(), std::uint64_t{0});
  const std::uint64_t by_secure_reason =
      std::accumulate(c.secure_rejected_by_reason.begin(), c.secure_rejected_by_reason.end(), std::uint64_t{0});
  EXPECT_EQ(c.rejected, by_reason + c.wrong_sender + by_secure_reason);
  EXPECT_EQ(c.rejected_by_reason[0], 0u) << "kOk is never a rejection";
}

inline std::uint64_t Rejected(const LinkCounters& c, proto::DecodeStatus status) {
  return c.rejected_by_reason[static_cast<std::size_t>(status)];
}

}  // namespace teleop::transport::test
