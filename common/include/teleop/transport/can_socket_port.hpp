#pragma once

#include <cstdint>
#include <string>

#include "teleop/proto/can/wire_format.hpp"
#include "teleop/transport/can_filter.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::transport {

/// True when this kernel can open a raw CAN socket (AF_CAN with can-raw loaded).
bool AfCanAvailable() noexcept;

/// A raw SocketCAN socket on `interface_name`, non-blocking, classic or FD (CAN_RAW_FD_FRAMES), with the receive
/// filters and error mask of `options` installed in the kernel (CAN_RAW_FILTER, CAN_RAW_ERR_FILTER). The default
/// error mask passes bus-off, error-passive/warning (controller), protocol, bus-error, no-ACK, TX-timeout,
/// transceiver and restarted error frames. Throws teleop::Error when the kernel has no AF_CAN, the interface does
/// not exist, FD is asked of a classic interface, there are more than kMaxCanFilters filters, or a socket call
/// fails. A link's port and a drive's port can share one interface: each socket sees only its own filters' frames.
class SocketCanPort final : public CanPort {
 public:
  SocketCanPort(const std::string& interface_name, const CanReceiveOptions& options);
  /// A CanLink's port: LinkReceiveOptions(format, local_role).
  SocketCanPort(const std::string& interface_name, const proto::can::CanWireFormat& format,
                proto::SenderRole local_role);
  ~SocketCanPort() override;

  [[nodiscard]] CanWriteStatus Write(const proto::can::CanFrame& frame) noexcept override;
  [[nodiscard]] bool Read(proto::can::CanFrame& frame) noexcept override;
  /// ppoll on the socket (POLLIN) until the deadline (CLOCK_MONOTONIC).
  [[nodiscard]] bool WaitReadable(std::int64_t deadline_ns) noexcept override;
  /// The kernel's receive timestamp of the last frame read (SO_TIMESTAMPNS), on CLOCK_MONOTONIC.
  std::int64_t receive_time_ns() const noexcept override { return receive_time_ns_; }
  std::string Describe() const override;

 private:
  int fd_ = -1;
  std::int64_t receive_time_ns_ = 0;
  bool fd_frames_ = false;
  std::size_t filter_count_ = 0;
  std::string interface_name_;
};

}  // namespace teleop::transport
