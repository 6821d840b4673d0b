#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace teleop::proto::can {

/// Largest data field of a classic CAN frame and of a CAN FD frame (bytes).
inline constexpr std::size_t kClassicMaxDataBytes = 8;
inline constexpr std::size_t kFdMaxDataBytes = 64;
/// Largest identifier value for 11-bit (standard) and 29-bit (extended) frames.
inline constexpr std::uint32_t kMaxStandardId = 0x7FF;
inline constexpr std::uint32_t kMaxExtendedId = 0x1FFFFFFF;

/// Error classes of an error frame. The values are those of SocketCAN's CAN_ERR_* (linux/can/error.h) so that a
/// SocketCAN error frame maps one to one; the SocketCAN port static_asserts the equality.
enum CanErrorClass : std::uint32_t {
  kErrTxTimeout = 0x001,        ///< TX timeout (by netdevice driver).
  kErrLostArbitration = 0x002,  ///< Lost arbitration (data[0] = bit).
  kErrController = 0x004,       ///< Controller problem (data[1] = kCtrl* bits).
  kErrProtocol = 0x008,         ///< Protocol violation (data[2], data[3]).
  kErrTransceiver = 0x010,      ///< Transceiver status (data[4]).
  kErrNoAck = 0x020,            ///< No acknowledge on transmission.
  kErrBusOff = 0x040,           ///< Bus off: the controller stopped taking part in bus traffic.
  kErrBusError = 0x080,         ///< Bus error (may flood).
  kErrRestarted = 0x100,        ///< Controller restarted after bus-off.
};

/// data[1] of a kErrController error frame (SocketCAN CAN_ERR_CRTL_*).
enum CanControllerError : std::uint8_t {
  kCtrlRxOverflow = 0x01,
  kCtrlTxOverflow = 0x02,
  kCtrlRxWarning = 0x04,  ///< Receive error counter reached the warning level (96).
  kCtrlTxWarning = 0x08,  ///< Transmit error counter reached the warning level (96).
  kCtrlRxPassive = 0x10,  ///< Receive error counter reached the error-passive level (128).
  kCtrlTxPassive = 0x20,  ///< Transmit error counter reached the error-passive level (128).
  kCtrlActive = 0x40,     ///< Back to error-active.
};

/// One frame as seen on the bus: a data frame (classic or FD) or an error frame reported by the controller.
/// Plain value type, trivially copyable, 80 bytes; no allocation.
struct CanFrame {
  std::uint32_t id = 0;           ///< 11- or 29-bit identifier, without flag bits.
  bool extended = false;          ///< 29-bit identifier.
  bool fd = false;                ///< CAN FD frame (data field up to 64 bytes).
  bool brs = false;               ///< FD bit-rate switch (data phase at the data bit rate).
  bool remote = false;            ///< Classic remote frame (never used by teleop: rejected).
  bool error = false;             ///< Error frame: `error_class` and `data` describe it, `id` is meaningless.
  std::uint8_t len = 0;           ///< Data bytes: 0..8 classic; FD: one of 0..8, 12, 16, 20, 24, 32, 48, 64.
  std::uint32_t error_class = 0;  ///< CanErrorClass bits when `error`.
  std::array<std::uint8_t, kFdMaxDataBytes> data{};
};

/// True when `len` is a length a CAN FD frame can have (0..8, 12, 16, 20, 24, 32, 48, 64).
bool IsValidFdLength(std::size_t len) noexcept;
/// The smallest FD frame length holding `bytes` (0 when bytes > 64).
std::size_t RoundUpToFdLength(std::size_t bytes) noexcept;

}  // namespace teleop::proto::can
