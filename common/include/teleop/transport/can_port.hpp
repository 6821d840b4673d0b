#pragma once

#include <string>

#include "teleop/proto/can/can_frame.hpp"

namespace teleop::transport {

/// Outcome of handing one frame to the medium.
enum class CanWriteStatus : std::uint8_t {
  kOk = 0,
  kBufferFull,  ///< Transmit queue full (ENOBUFS/EAGAIN): the bus is saturated.
  kBusOff,      ///< The controller is bus-off: it takes no part in bus traffic until restarted.
  kError,       ///< Any other failure (interface down, daemon gone).
};

const char* ToString(CanWriteStatus status) noexcept;

/// One node's access to a CAN medium (SocketCAN socket, in-process emulated bus, teleop-canbus client). Both calls
/// are made from the real-time thread: non-blocking, no allocation, no throw. Error frames are read like data
/// frames, with `error` set.
class CanPort {
 public:
  CanPort() = default;
  virtual ~CanPort() = default;
  CanPort(const CanPort&) = delete;
  CanPort& operator=(const CanPort&) = delete;

  [[nodiscard]] virtual CanWriteStatus Write(const proto::can::CanFrame& frame) noexcept = 0;
  /// Reads one pending frame; false when none is pending.
  [[nodiscard]] virtual bool Read(proto::can::CanFrame& frame) noexcept = 0;
  virtual std::string Describe() const = 0;
  /// What the port adds to the link's run summary (e.g. its candump log's counts); empty by default.
  virtual std::string Summary() const { return {}; }
};

}  // namespace teleop::transport
