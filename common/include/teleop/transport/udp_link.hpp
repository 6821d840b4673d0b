#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "teleop/transport/link.hpp"
#include "teleop/transport/link_security.hpp"

namespace teleop::transport {

struct UdpLinkConfig {
  std::string bind_address = "127.0.0.1";  ///< IPv4 or IPv6 literal; "0.0.0.0" binds every interface.
  std::uint16_t bind_port = 0;             ///< 0: the kernel picks one (see UdpLink::local_port()).
  std::string peer_address = "127.0.0.1";  ///< Same address family as bind_address.
  std::uint16_t peer_port = 0;             ///< 0: no peer yet; set it with UdpLink::SetPeer before sending.
  proto::SenderRole expected_peer = proto::SenderRole::kSlave;  ///< Samples from any other role are rejected.
  /// Reject datagrams whose source is not peer_address:peer_port. With a peer set, the socket is also connect()ed
  /// to it, so the kernel drops other sources before they reach the queue.
  bool accept_only_peer_address = true;
  /// SO_RCVBUF (bytes; an explicit value the kernel refuses is an error). 0: the link asks for 4 MiB (SO_RCVBUFFORCE
  /// with CAP_NET_ADMIN, else capped at net.core.rmem_max); receive_buffer_bytes() reports what the kernel took.
  int receive_buffer_bytes = 0;
  /// SO_BUSY_POLL (µs): the kernel busy-polls the device queue in a receive instead of waiting for the interrupt.
  /// 0 = off. Raising it above net.core.busy_read needs CAP_NET_ADMIN; when refused the link runs without it and
  /// busy_poll_applied() says so (not an error). No effect on loopback (no NAPI queue to poll).
  int busy_poll_us = 0;
  /// Spin receive (µs): when a Poll() finds no new sample, keep polling for up to this long before giving up
  /// (a spin before the deadline, for a sample known to be due). 0 = off: Poll() drains once and returns.
  int spin_poll_us = 0;
  /// kPsk: every datagram goes through a SecureSession (docs/security.md); the key file is loaded in the
  /// constructor. security.session.dof must be the process's DOF; its role is set from expected_peer.
  LinkSecurityConfig security{};
  /// kPsk, master: an established session whose peer sent no authenticated sample for this long is re-handshaken
  /// (the slave may have restarted). The process sets it to link.timeout_ms.
  double peer_silence_ms = 50.0;
};

/// UDP on Boost.Asio: a non-blocking socket bound to bind_address:bind_port, sending to the peer. Poll() drains
/// the socket each cycle (at most kMaxDatagramsPerPoll, so a flood cannot stall the loop) and keeps the newest
/// sequence (see Link). Send and Poll use buffers allocated in the constructor: no allocation, no exception.
///
/// The socket is connect()ed to the peer when accept_only_peer_address is set, so the kernel drops other sources.
///
/// Authenticated mode (security.mode kPsk): Poll passes every datagram from the peer's address to the session,
/// sends its handshake replies, and feeds only authenticated samples to the keep-the-newest logic; everything else
/// is counted by reason (LinkCounters::secure_rejected_by_reason). Send seals. The master drives the handshake
/// from Poll: a hello at the first Poll and every handshake_retry_ms while no session is established or the peer
/// has been silent for peer_silence_ms. A new session increments session_epoch() and resets the sequence tracker.
/// The session runs its X25519 on its own helper thread (SecureSessionConfig::offload_key_exchange): each Poll first
/// collects a finished key exchange (SecureSession::Pump) and sends the welcome or confirm it calls for.
///
/// Receive times: the socket has SO_TIMESTAMPNS, so every datagram carries the kernel's receive time, which the
/// kernel takes in CLOCK_REALTIME. Poll() converts the one of the newest accepted sample to CLOCK_MONOTONIC (the
/// loop's clock) with the offset realtime - monotonic read at that Poll, and clamps it to not later than the Poll
/// (newest_receive_time_ns()). The conversion is exact unless the realtime clock is stepped (settimeofday, an NTP
/// step) between the datagram's arrival and the Poll; NTP slewing changes the offset by at most 500 ppm of that
/// interval (< 1 µs for a sample a millisecond old).
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
  /// Polls until a new sample arrives or CLOCK_MONOTONIC reaches `deadline_ns` (a busy spin, for a sample known to
  /// be due; no sleep). Returns what the last Poll() returned. Real-time safe.
  [[nodiscard]] bool PollUntil(proto::SampleMessage& newest, std::int64_t deadline_ns) noexcept;
  /// poll() on the socket until a datagram is pending or the deadline passes.
  [[nodiscard]] bool WaitReadable(std::int64_t deadline_ns) noexcept override;
  std::int64_t newest_receive_time_ns() const noexcept override { return newest_receive_time_ns_; }
  std::uint64_t session_epoch() const noexcept override { return counters_.sessions; }
  /// True when the newest sample's receive time came from the kernel (false: the datagram had no timestamp and
  /// the time is when Poll read it).
  bool newest_receive_time_from_kernel() const noexcept { return newest_from_kernel_; }
  /// Whether SO_BUSY_POLL with config busy_poll_us was accepted by the kernel (false when off or refused).
  bool busy_poll_applied() const noexcept { return busy_poll_applied_; }
  const LinkCounters& counters() const noexcept override { return counters_; }
  std::string Describe() const override;
  /// The bound local port (useful with bind_port = 0 in tests).
  std::uint16_t local_port() const noexcept;
  /// SO_RCVBUF read back from the kernel (Linux reports twice the payload it grants; Describe() shows it).
  int receive_buffer_bytes() const noexcept;
  /// Whether the socket is connect()ed to the peer (accept_only_peer_address with a peer set).
  bool connected() const noexcept;
  /// Set-up only (not from the loop): sets or changes the peer. Throws teleop::Error on an invalid address.
  void SetPeer(const std::string& address, std::uint16_t port);

 private:
  struct Impl;
  bool PollOnce(proto::SampleMessage& newest, std::int64_t poll_monotonic_ns,
                std::int64_t realtime_minus_monotonic_ns) noexcept;
  /// Authenticated mode: one datagram through the session. True when it is now the newest sample of this drain.
  bool OfferSecure(std::size_t length, std::int64_t now_ns) noexcept;
  /// Authenticated mode: a finished key exchange of the session's helper thread (its welcome or confirm sent), and
  /// the bookkeeping of a new session.
  void PumpSession(std::int64_t now_ns) noexcept;
  void NoteSession(std::int64_t now_ns) noexcept;
  /// Authenticated mode, master: a hello when none is established or the peer went silent.
  void DriveHandshake(std::int64_t now_ns) noexcept;
  void SendRaw(const std::uint8_t* bytes, std::size_t size) noexcept;
  bool SendBytes(const std::uint8_t* bytes, std::size_t size) noexcept;

  std::unique_ptr<Impl> impl_;
  LinkCounters counters_{};
  std::int64_t newest_receive_time_ns_ = 0;
  bool newest_from_kernel_ = false;
  bool busy_poll_applied_ = false;
  int busy_poll_us_ = 0;  ///< As configured (Describe() says whether the kernel took it).
  std::int64_t spin_poll_ns_ = 0;
};

}  // namespace teleop::transport
