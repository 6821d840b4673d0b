#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "teleop/transport/link.hpp"

namespace teleop::transport {

struct UdpLinkConfig {
  std::string bind_address = "127.0.0.1";
  std::uint16_t bind_port = 0;
  std::string peer_address = "127.0.0.1";
  std::uint16_t peer_port = 0;
  proto::SenderRole expected_peer = proto::SenderRole::kSlave;  ///< Samples from any other role are rejected.
  bool accept_only_peer_address = true;  ///< Reject datagrams whose source is not peer_address:peer_port.
  int receive_buffer_bytes = 0;          ///< SO_RCVBUF; 0 = kernel default.
};

/// UDP on Boost.Asio: a non-blocking socket bound to bind_address:bind_port, sending to the peer. Poll() drains
/// the socket each cycle and keeps the newest sequence (see Link).
class UdpLink final : public Link {
 public:
  explicit UdpLink(const UdpLinkConfig& config);
  ~UdpLink() override;

  [[nodiscard]] bool Send(const proto::SampleMessage& message) noexcept override;
  [[nodiscard]] bool Poll(proto::SampleMessage& newest) noexcept override;
  const LinkCounters& counters() const noexcept override { return counters_; }
  std::string Describe() const override;
  /// The bound local port (useful with bind_port = 0 in tests).
  std::uint16_t local_port() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  LinkCounters counters_{};
};

}  // namespace teleop::transport
