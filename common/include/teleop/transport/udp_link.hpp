#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "teleop/transport/link.hpp"

namespace teleop::transport {

struct UdpLinkConfig {
  std::string bind_address = "127.0.0.1";  ///< IPv4 or IPv6 literal; "0.0.0.0" binds every interface.
  std::uint16_t bind_port = 0;             ///< 0: the kernel picks one (see UdpLink::local_port()).
  std::string peer_address = "127.0.0.1";  ///< Same address family as bind_address.
  std::uint16_t peer_port = 0;             ///< 0: no peer yet; set it with UdpLink::SetPeer before sending.
  proto::SenderRole expected_peer = proto::SenderRole::kSlave;  ///< Samples from any other role are rejected.
  bool accept_only_peer_address = true;  ///< Reject datagrams whose source is not peer_address:peer_port.
  int receive_buffer_bytes = 0;          ///< SO_RCVBUF; 0 = kernel default.
};

/// UDP on Boost.Asio: a non-blocking socket bound to bind_address:bind_port, sending to the peer. Poll() drains
/// the socket each cycle (at most kMaxDatagramsPerPoll, so a flood cannot stall the loop) and keeps the newest
/// sequence (see Link). Send and Poll use buffers allocated in the constructor: no allocation, no exception.
class UdpLink final : public Link {
 public:
  /// Bound on datagrams read in one Poll. At 4 kHz that is a second of backlog from a peer at the same rate.
  static constexpr int kMaxDatagramsPerPoll = 4096;

  /// Opens and binds the socket. Throws teleop::Error naming the address on an invalid address, a failed bind
  /// (port in use, address not local) or an SO_RCVBUF the kernel refuses.
  explicit UdpLink(const UdpLinkConfig& config);
  ~UdpLink() override;

  [[nodiscard]] bool Send(const proto::SampleMessage& message) noexcept override;
  [[nodiscard]] bool Poll(proto::SampleMessage& newest) noexcept override;  // NOLINT(bugprone-exception-escape)
  const LinkCounters& counters() const noexcept override { return counters_; }
  std::string Describe() const override;
  /// The bound local port (useful with bind_port = 0 in tests).
  std::uint16_t local_port() const noexcept;
  /// Set-up only (not from the loop): sets or changes the peer. Throws teleop::Error on an invalid address.
  void SetPeer(const std::string& address, std::uint16_t port);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  LinkCounters counters_{};
};

}  // namespace teleop::transport
