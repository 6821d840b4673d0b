#pragma once

#include <cstdint>
#include <string>

#include "teleop/transport/can_bus_datagram.hpp"
#include "teleop/transport/can_filter.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::transport {

/// A node of the teleop-canbus daemon (transport "emulated-can"): frames go to the daemon over UDP (`host` an IPv4
/// address) or a Unix-domain SOCK_SEQPACKET socket (`host` = `unix:PATH`, `port` unused; the socket file's
/// permissions say who may join, the daemon reads the peer's uid from the kernel), and come back
/// when the emulated bus has carried them. The constructor attaches (kHello/kWelcome) and throws teleop::Error with
/// what to run when no daemon answers within `timeout_ms`. The daemon forwards every frame; `options` filters them
/// here with SocketCAN's rules (Accepts), so a driver sees what it would see on a real interface.
class UdpCanBusPort final : public CanPort {
 public:
  UdpCanBusPort(const std::string& host, std::uint16_t port, double timeout_ms,
                CanReceiveOptions options = CanReceiveOptions::Everything());
  ~UdpCanBusPort() override;

  [[nodiscard]] CanWriteStatus Write(const proto::can::CanFrame& frame) noexcept override;
  [[nodiscard]] bool Read(proto::can::CanFrame& frame) noexcept override;
  /// ppoll on the node's UDP socket until the deadline (CLOCK_MONOTONIC).
  [[nodiscard]] bool WaitReadable(std::int64_t deadline_ns) noexcept override;
  /// The kernel's receive timestamp (SO_TIMESTAMPNS) of the daemon's datagram that carried the last frame read:
  /// the end of the frame's transmission on the emulated bus plus the loopback hop, on CLOCK_MONOTONIC.
  std::int64_t receive_time_ns() const noexcept override { return receive_time_ns_; }
  std::string Describe() const override;

  int node() const noexcept { return node_; }
  /// Fault injection through the daemon (tests, demos). False when the datagram could not be sent.
  bool SendControl(bus_datagram::Action action, std::uint32_t argument) noexcept;

  /// UDP: a node that has sent nothing for this long sends a hello from Read (the daemon detaches a node silent
  /// for CanBusServerConfig::node_timeout_ms, 2000 ms by default).
  static constexpr std::int64_t kKeepAlive_ms = 500;

 private:
  void Sent() noexcept;

  int socket_ = -1;
  bool unix_ = false;
  std::int64_t last_sent_ns_ = 0;  ///< CLOCK_MONOTONIC of the last datagram sent to the daemon.
  int node_ = -1;
  std::int64_t receive_time_ns_ = 0;
  CanReceiveOptions options_;
  std::string endpoint_;
};

}  // namespace teleop::transport
