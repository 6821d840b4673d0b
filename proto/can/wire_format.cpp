#include "teleop/proto/can/wire_format.hpp"

#include "teleop/proto/can/can_frame.hpp"
#include "teleop/proto/can/frame_layout.hpp"

namespace teleop::proto::can {

namespace {

bool DofFits(const CanWireFormat& format) noexcept {
  return format.dof >= 1 && format.dof <= (format.fd ? kMaxWireDof : kMaxClassicDof);
}

}  // namespace

int FramesPerCycle(const CanWireFormat& format) noexcept {
  if (!DofFits(format)) return 0;
  return format.fd ? 1 : SlotCount(format.dof);
}

FormatStatus CheckFormat(const CanWireFormat& format) noexcept {
  if (!DofFits(format)) return FormatStatus::kBadDof;
  const std::uint32_t max_id = format.extended_id ? kMaxExtendedId : kMaxStandardId;
  const std::uint32_t m = format.master_to_slave_base_id;
  const std::uint32_t s = format.slave_to_master_base_id;
  if (m > max_id - (kIdSpan - 1) || s > max_id - (kIdSpan - 1)) return FormatStatus::kIdOutOfRange;
  if (m < s + kIdSpan && s < m + kIdSpan) return FormatStatus::kIdRangesOverlap;
  return FormatStatus::kOk;
}

const char* ToString(FormatStatus status) noexcept {
  switch (status) {
    case FormatStatus::kOk:
      return "ok";
    case FormatStatus::kBadDof:
      return "dof outside 1..6 (classic CAN) or 1..12 (CAN FD)";
    case FormatStatus::kIdOutOfRange:
      return "base identifier + 4 does not fit the identifier width";
    case FormatStatus::kIdRangesOverlap:
      return "master->slave and slave->master identifier ranges (base..base+4) overlap";
  }
  return "invalid";
}

}  // namespace teleop::proto::can
