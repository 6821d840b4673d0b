#pragma once

#include <cstdint>
#include <ctime>
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

  /// Waits until a frame (data or error) is pending (true) or the port's clock (now_ns()) reaches `deadline_ns`
  /// (false; also when a signal interrupts the wait). Returns at once when a frame is already pending, whatever
  /// the deadline. Nothing is consumed (Read() reads it), and what is pending may still be filtered out or
  /// rejected. A CanLink uses it to start a triggered slave's cycle when the master's whole sample has arrived
  /// (docs/can.md, "Phase-locked cycles over CAN"). The default, for a medium that cannot wait, sleeps until the
  /// deadline on CLOCK_MONOTONIC and returns false. Real-time safe: no allocation, no lock, no throw.
  [[nodiscard]] virtual bool WaitReadable(std::int64_t deadline_ns) noexcept {
    constexpr std::int64_t kNsPerS = 1'000'000'000;
    timespec until{};
    until.tv_sec = static_cast<time_t>(deadline_ns / kNsPerS);
    until.tv_nsec = static_cast<long>(deadline_ns % kNsPerS);
    (void)clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr);
    return false;
  }
  /// The clock WaitReadable's deadline and receive_time_ns() are on (ns): CLOCK_MONOTONIC, except for an emulated
  /// bus on a caller's clock (tests). Real-time safe.
  virtual std::int64_t now_ns() const noexcept {
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
  }
  /// When the medium received the frame the last successful Read() returned, on now_ns()'s clock (the kernel's
  /// receive timestamp on SocketCAN and teleop-canbus, the end of its transmission on the in-process emulated
  /// bus); 0 when the port does not know.
  virtual std::int64_t receive_time_ns() const noexcept { return 0; }

  /// What the port adds to the link's run summary (e.g. its candump log's counts); empty by default.
  virtual std::string Summary() const { return {}; }
};

}  // namespace teleop::transport
