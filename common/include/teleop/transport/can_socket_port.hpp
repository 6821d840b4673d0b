#pragma once

#include <string>

#include "teleop/proto/can/wire_format.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::transport {

/// True when this kernel can open a raw CAN socket (AF_CAN with can-raw loaded).
bool AfCanAvailable() noexcept;

/// A raw SocketCAN socket on `interface_name`, non-blocking, classic or FD (CAN_RAW_FD_FRAMES). Receive filters
/// pass only the peer's identifiers of `format`; the error mask passes bus-off, error-passive/warning (controller),
/// protocol, bus-error, no-ACK, TX-timeout, transceiver and restarted error frames. Throws teleop::Error when the
/// kernel has no AF_CAN, the interface does not exist, FD is asked of a classic interface, or a socket call fails.
class SocketCanPort final : public CanPort {
 public:
  SocketCanPort(const std::string& interface_name, const proto::can::CanWireFormat& format,
                proto::SenderRole local_role);
  ~SocketCanPort() override;

  [[nodiscard]] CanWriteStatus Write(const proto::can::CanFrame& frame) noexcept override;
  [[nodiscard]] bool Read(proto::can::CanFrame& frame) noexcept override;
  std::string Describe() const override;

 private:
  int fd_ = -1;
  bool fd_frames_ = false;
  std::string interface_name_;
};

}  // namespace teleop::transport
