#pragma once

#include <array>
#include <cstdint>
#include <ctime>
#include <string>

#include "teleop/proto/codec.hpp"
#include "teleop/proto/sample_message.hpp"
#include "teleop/transport/secure_status.hpp"
#include "teleop/transport/sequence_tracker.hpp"  // IWYU pragma: export

namespace teleop::transport {

/// What a link counts. Every datagram/frame read is counted under exactly one outcome:
///   received == accepted + superseded + reordered + duplicates + rejected + handshake_messages
/// and rejected == sum(rejected_by_reason) + wrong_sender + sum(secure_rejected_by_reason).
struct LinkCounters {
  std::uint64_t sent = 0;
  std::uint64_t send_errors = 0;  ///< Socket/bus refused a send (buffer full, bus-off, ...).
  std::uint64_t received = 0;     ///< Datagrams/frames read from the medium, before validation.
  std::uint64_t accepted = 0;     ///< Decoded, from the expected peer, newer than anything before.
  std::uint64_t lost = 0;         ///< Sequence gaps: numbers never seen (late arrivals are subtracted).
  std::uint64_t reordered = 0;    ///< Arrived after a newer one (stale): counted, not applied.
  std::uint64_t duplicates = 0;   ///< Same sequence as one already accepted.
  std::uint64_t rejected = 0;     ///< Malformed (rejected_by_reason) or foreign (wrong_sender).
  std::array<std::uint64_t, static_cast<std::size_t>(proto::DecodeStatus::kCount)> rejected_by_reason{};
  std::uint64_t wrong_sender = 0;  ///< From an unexpected role or source address (also in rejected).
  std::uint64_t superseded = 0;    ///< Valid and in order, but a newer one arrived in the same drain.
  std::uint64_t bus_errors = 0;    ///< CAN error frames, socket receive errors and similar medium faults.
  // Authenticated session (link.security.mode psk, docs/security.md); all zero on an insecure link.
  /// Datagrams the session refused, indexed by SecureReceiveStatus (kSample and kHandshake stay 0); also in rejected.
  std::array<std::uint64_t, kSecureStatusCount> secure_rejected_by_reason{};
  std::uint64_t handshake_messages = 0;  ///< Valid handshake messages received (neither samples nor rejected).
  std::uint64_t sessions = 0;            ///< Sessions established (Link::session_epoch()).
  std::uint64_t handshakes_started = 0;  ///< Hellos sent (master) or answered (slave).
  std::uint64_t send_no_session = 0;     ///< Send() while no session exists: nothing sent (not a send error).
  /// The version byte of the newest datagram that carried the teleop magic but a wire protocol version this link
  /// does not speak (also counted in rejected): the peer runs other software, or the other security mode. 0: none.
  std::uint8_t peer_protocol_version = 0;
};

/// A bidirectional sample link to the peer process. Both calls are made from the real-time thread: non-blocking,
/// allocation-free, never throw. Opening the medium happens in the constructor and may throw teleop::Error.
class Link {
 public:
  virtual ~Link() = default;
  Link() = default;
  Link(const Link&) = delete;
  Link& operator=(const Link&) = delete;

  /// Sends one sample. Returns false (and counts a send error) when the medium refused it.
  [[nodiscard]] virtual bool Send(const proto::SampleMessage& message) noexcept = 0;
  /// Drains everything pending. When at least one sample newer than any before arrived, writes the newest to
  /// `newest` and returns true; otherwise leaves `newest` alone and returns false.
  [[nodiscard]] virtual bool Poll(proto::SampleMessage& newest) noexcept = 0;

  /// Waits until the medium has something to read (true) or CLOCK_MONOTONIC reaches `deadline_ns` (false); false
  /// also when a signal interrupts the wait. What is readable is not consumed (Poll() reads it) and may still be
  /// rejected. Used by a triggered slave to start its cycle when the master's sample arrives. The default (a link
  /// that cannot wait on its medium) sleeps until the deadline and returns false. Real-time safe.
  [[nodiscard]] virtual bool WaitReadable(std::int64_t deadline_ns) noexcept {
    constexpr std::int64_t kNsPerS = 1'000'000'000;
    timespec until{};
    until.tv_sec = static_cast<time_t>(deadline_ns / kNsPerS);
    until.tv_nsec = static_cast<long>(deadline_ns % kNsPerS);
    (void)clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr);
    return false;
  }

  virtual const LinkCounters& counters() const noexcept = 0;
  /// Short description for logs ("udp 127.0.0.1:47001 -> 127.0.0.1:47002").
  virtual std::string Describe() const = 0;
  /// True while the medium itself is down (CAN bus-off): the node treats the peer as lost at once instead of
  /// waiting for the watchdog. Real-time safe.
  virtual bool faulted() const noexcept { return false; }
  /// CLOCK_MONOTONIC time (ns) at which the medium received the sample the last successful Poll() returned: the
  /// kernel's receive timestamp where the link has one (UDP), else the time that Poll read it. 0 before the first
  /// sample, or when the link does not know. Real-time safe.
  virtual std::int64_t newest_receive_time_ns() const noexcept { return 0; }
  /// Counts the authenticated sessions this link has established with its peer (0 on a link without sessions, or
  /// before the first). It changes exactly when a new session starts, e.g. after a peer restart: the node treats
  /// that as a new peer and re-engages only through aligning. Real-time safe.
  virtual std::uint64_t session_epoch() const noexcept { return 0; }
  /// Medium-specific counters for the end-of-run summary (CAN frames by status, bus load); empty when none.
  virtual std::string Summary() const { return {}; }
};

}  // namespace teleop::transport
