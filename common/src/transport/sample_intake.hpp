#pragma once

// Private to the transport libraries: the receive path every link shares (UDP, emulated, CAN), so that each one
// validates, counts and keeps the newest sample in exactly the same way.

#include <cstdint>
#include <span>

#include "teleop/proto/codec.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::transport::detail {

/// One Poll: Begin(), then Offer() or OfferForeign() per datagram read, then Finish(). No allocation, no throw.
class SampleIntake {
 public:
  explicit SampleIntake(proto::SenderRole expected_peer) noexcept : expected_peer_(expected_peer) {}

  void Begin() noexcept { has_pending_ = false; }
  /// A sample newer than any before is waiting for Finish() in this drain.
  bool has_pending() const noexcept { return has_pending_; }

  /// A datagram from the expected source: decode, check the role, classify its sequence. Returns true when it is
  /// now the newest sample of this drain (what Finish() will hand back unless a newer one follows).
  bool Offer(std::span<const std::uint8_t> bytes, LinkCounters& counters) noexcept {
    ++counters.received;
    const proto::DecodeStatus status = proto::DecodeSample(bytes, scratch_);
    if (status != proto::DecodeStatus::kOk) {
      ++counters.rejected;
      ++counters.rejected_by_reason[static_cast<std::size_t>(status)];
      if (status == proto::DecodeStatus::kBadVersion) NoteVersion(bytes, counters);
      return false;
    }
    if (scratch_.sender != expected_peer_) {
      ++counters.rejected;
      ++counters.wrong_sender;
      return false;
    }
    if (tracker_.Observe(scratch_.sequence, counters) != SequenceTracker::Verdict::kNewer) return false;
    if (has_pending_) ++counters.superseded;
    pending_ = scratch_;
    has_pending_ = true;
    return true;
  }

  /// A sample decoded by the link itself (CAN: reassembled from frames whose identifiers gave the sender): counted
  /// as received and classified by its sequence exactly as Offer() does. The verdict lets the link resynchronise.
  SequenceTracker::Verdict OfferDecoded(const proto::SampleMessage& sample, LinkCounters& counters) noexcept {
    ++counters.received;
    const SequenceTracker::Verdict verdict = tracker_.Observe(sample.sequence, counters);
    if (verdict != SequenceTracker::Verdict::kNewer) return verdict;
    if (has_pending_) ++counters.superseded;
    pending_ = sample;
    has_pending_ = true;
    return verdict;
  }

  /// A unit the link refused before it became a sample (a malformed CAN frame, a partial cycle).
  void Reject(proto::DecodeStatus reason, LinkCounters& counters) noexcept {
    ++counters.received;
    ++counters.rejected;
    ++counters.rejected_by_reason[static_cast<std::size_t>(reason)];
  }

  /// Authenticated link: a valid handshake message (neither a sample nor a rejection).
  void OfferHandshake(LinkCounters& counters) noexcept {
    ++counters.received;
    ++counters.handshake_messages;
  }

  /// Authenticated link: a datagram the session refused (forged, replayed, old session, version 1, ...).
  void RejectSecure(SecureReceiveStatus reason, std::span<const std::uint8_t> bytes, LinkCounters& counters) noexcept {
    ++counters.received;
    ++counters.rejected;
    ++counters.secure_rejected_by_reason[static_cast<std::size_t>(reason)];
    if (reason == SecureReceiveStatus::kMalformed || reason == SecureReceiveStatus::kInsecure) {
      NoteVersion(bytes, counters);
    }
  }

  /// A datagram with the teleop magic and a version byte that is not `expected`'s: the peer's protocol version, for
  /// the status line and the summary (LinkCounters::peer_protocol_version).
  static void NoteVersion(std::span<const std::uint8_t> bytes, LinkCounters& counters) noexcept {
    if (bytes.size() <= proto::wire::kVersionOffset) return;
    const std::uint32_t magic = static_cast<std::uint32_t>(bytes[0]) | static_cast<std::uint32_t>(bytes[1]) << 8u |
                                static_cast<std::uint32_t>(bytes[2]) << 16u |
                                static_cast<std::uint32_t>(bytes[3]) << 24u;
    if (magic == proto::wire::kMagic) counters.peer_protocol_version = bytes[proto::wire::kVersionOffset];
  }

  /// Drops the sample pending in this drain (it belongs to a session that just ended), counted as superseded.
  void DropPending(LinkCounters& counters) noexcept {
    if (has_pending_) ++counters.superseded;
    has_pending_ = false;
  }

  /// The newest sequence accepted (CAN extends its 4-bit counter from it); Reset forgets it.
  const SequenceTracker& tracker() const noexcept { return tracker_; }
  void ResetTracker() noexcept { tracker_.Reset(); }

  /// A datagram from a source address other than the peer's: not even decoded.
  void OfferForeign(LinkCounters& counters) noexcept {
    ++counters.received;
    ++counters.rejected;
    ++counters.wrong_sender;
  }

  /// Hands back the newest sample of this drain, if any.
  bool Finish(proto::SampleMessage& newest, LinkCounters& counters) noexcept {
    if (!has_pending_) return false;
    ++counters.accepted;
    newest = pending_;
    has_pending_ = false;
    return true;
  }

  proto::SenderRole expected_peer() const noexcept { return expected_peer_; }

 private:
  proto::SenderRole expected_peer_;
  SequenceTracker tracker_{};
  proto::SampleMessage scratch_{};
  proto::SampleMessage pending_{};
  bool has_pending_ = false;
};

}  // namespace teleop::transport::detail
