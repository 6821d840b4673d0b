#pragma once

// Shared by the CAN link tests: a manual clock for the emulated bus and sample builders.

#include <cstdint>

#include "teleop/proto/sample_message.hpp"

namespace teleop::transport::test {

/// A clock the test moves by hand (ns).
struct ManualClock {
  std::uint64_t now_ns = 0;
  std::uint64_t operator()() const noexcept { return now_ns; }
};

/// A sample whose fields encode `sequence` mod 16 (what the CAN counter carries) so that a torn or mixed sample is
/// visible: position = 1e-4·k, velocity = -1e-2·k, force = 0.1·k + DOF index, k = sequence mod 16.
inline proto::SampleMessage MakeSample(proto::SenderRole sender, int dof, std::uint32_t sequence) {
  proto::SampleMessage m{};
  m.sender = sender;
  m.dof = static_cast<std::uint8_t>(dof);
  m.sequence = sequence;
  m.flags = proto::kFlagEnabled;
  const double k = static_cast<double>(sequence % 16);
  for (int d = 0; d < dof; ++d) {
    const auto j = static_cast<std::size_t>(d);
    m.position_m[j] = 1e-4 * k;
    m.velocity_m_per_s[j] = -1e-2 * k;
    m.force_N[j] = 0.1 * k + d;
  }
  return m;
}

/// True when every field of `m` is what MakeSample gives for `m.sequence` (within half an LSB).
inline bool ConsistentSample(const proto::SampleMessage& m) {
  const double k = static_cast<double>(m.sequence % 16);
  for (int d = 0; d < m.dof; ++d) {
    const auto j = static_cast<std::size_t>(d);
    if (m.position_m[j] - 1e-4 * k > 1.01e-5 || 1e-4 * k - m.position_m[j] > 1.01e-5) return false;
    if (m.velocity_m_per_s[j] + 1e-2 * k > 1.01e-3 || -1e-2 * k - m.velocity_m_per_s[j] > 1.01e-3) return false;
    if (m.force_N[j] - (0.1 * k + d) > 5.1e-3 || (0.1 * k + d) - m.force_N[j] > 5.1e-3) return false;
  }
  return true;
}

}  // namespace teleop::transport::test
