#pragma once

#include <cstdint>

#include "teleop/proto/sample_message.hpp"

namespace teleop::proto::can {

/// What both ends of a CAN link must agree on (the receiver checks every frame against it).
struct CanWireFormat {
  int dof = 3;                                    ///< 1..kMaxClassicDof (6) classic, 1..kMaxWireDof (12) FD.
  bool fd = false;                                ///< One CAN FD frame per cycle instead of classic frames.
  bool brs = true;                                ///< FD bit-rate switch in sent frames (ignored for classic).
  bool extended_id = false;                       ///< 29-bit identifiers.
  std::uint32_t master_to_slave_base_id = 0x100;  ///< Master's frames: base + 0..3 (classic), base + 4 (FD).
  std::uint32_t slave_to_master_base_id = 0x180;  ///< Slave's frames, same scheme.
};

/// Base identifier of the frames `sender` sends.
constexpr std::uint32_t BaseIdOf(const CanWireFormat& format, SenderRole sender) noexcept {
  return sender == SenderRole::kMaster ? format.master_to_slave_base_id : format.slave_to_master_base_id;
}

/// Frames one direction sends per cycle: SlotCount(dof) classic frames, or 1 FD frame.
int FramesPerCycle(const CanWireFormat& format) noexcept;

/// Why a format is unusable; kOk when both ends can use it.
enum class FormatStatus : std::uint8_t {
  kOk,
  kBadDof,           ///< dof outside 1..kMaxClassicDof (classic) or 1..kMaxWireDof (FD).
  kIdOutOfRange,     ///< base + kIdSpan - 1 does not fit 11 (or 29) bits.
  kIdRangesOverlap,  ///< The two directions' identifier ranges overlap.
};
[[nodiscard]] FormatStatus CheckFormat(const CanWireFormat& format) noexcept;
const char* ToString(FormatStatus status) noexcept;

}  // namespace teleop::proto::can
