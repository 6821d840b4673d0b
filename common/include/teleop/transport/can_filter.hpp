#pragma once

#include <cstdint>
#include <vector>

#include "teleop/proto/can/can_frame.hpp"
#include "teleop/proto/can/wire_format.hpp"

namespace teleop::transport {

/// One receive filter with SocketCAN's semantics (linux/can.h `struct can_filter`): a data frame passes when
/// (frame_id & mask) == (id & mask), where both words carry the identifier in bits 0..28, the extended-frame flag in
/// bit 31 (kExtendedFlag, CAN_EFF_FLAG) and the remote flag in bit 30 (kRemoteFlag, CAN_RTR_FLAG). `invert` passes
/// the frames that do not match (CAN_INV_FILTER). The same function decides on every medium (SocketCAN in the
/// kernel, the emulated buses in software), so a driver sees the same frames everywhere.
struct CanFilter {
  static constexpr std::uint32_t kExtendedFlag = 0x8000'0000u;
  static constexpr std::uint32_t kRemoteFlag = 0x4000'0000u;

  std::uint32_t id = 0;
  std::uint32_t mask = 0;
  bool invert = false;

  /// Data frames with exactly identifier `id` of the given width.
  static CanFilter Exact(std::uint32_t id, bool extended = false) noexcept;
  /// Data frames of the given width whose identifier equals `id` in the bits set in `id_mask`.
  static CanFilter Masked(std::uint32_t id, std::uint32_t id_mask, bool extended = false) noexcept;
  /// Every data frame (and remote frame), either width.
  static CanFilter All() noexcept;
};

/// Error classes (proto::can::CanErrorClass bits) a port passes unless told otherwise: everything a link or a
/// driver must react to. SocketCAN's own default is none, which hides bus-off and error-passive (field notes).
inline constexpr std::uint32_t kDefaultCanErrorMask =
    proto::can::kErrTxTimeout | proto::can::kErrController | proto::can::kErrProtocol | proto::can::kErrTransceiver |
    proto::can::kErrNoAck | proto::can::kErrBusOff | proto::can::kErrBusError | proto::can::kErrRestarted;

/// What a port receives. Set-up data: the filters are copied into the kernel (SocketCAN) or into the port.
struct CanReceiveOptions {
  /// A data frame passes when any filter passes it. Empty: no data frames at all (error frames only).
  std::vector<CanFilter> filters{CanFilter::All()};
  std::uint32_t error_mask = kDefaultCanErrorMask;  ///< Error classes passed; 0: no error frames.
  bool fd = false;  ///< CAN FD frames are sent and received (SocketCAN CAN_RAW_FD_FRAMES); else FD frames are dropped.

  /// Every frame: all data frames, classic and FD, every error class (monitors, candump-like taps, old callers).
  static CanReceiveOptions Everything();
};

/// Largest number of filters a port takes (SocketCAN allows more; a driver never needs that many).
inline constexpr std::size_t kMaxCanFilters = 64;

/// True when `filter` passes data frame `frame` (error frames are never matched by filters).
[[nodiscard]] bool Matches(const CanFilter& filter, const proto::can::CanFrame& frame) noexcept;
/// What a SocketCAN raw socket set up with `options` delivers: error frames by error_mask, FD frames only with fd,
/// data frames by the filters. No allocation.
[[nodiscard]] bool Accepts(const CanReceiveOptions& options, const proto::can::CanFrame& frame) noexcept;

/// The receive options of a CanLink of role `local_role`: the peer's identifiers of `format` only (base .. base+4),
/// FD as the format says, the default error mask.
CanReceiveOptions LinkReceiveOptions(const proto::can::CanWireFormat& format, proto::SenderRole local_role);

}  // namespace teleop::transport
