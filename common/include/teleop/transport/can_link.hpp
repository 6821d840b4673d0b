#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "teleop/proto/can/sample_codec.hpp"
#include "teleop/transport/can_link_config.hpp"
#include "teleop/transport/can_port.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::transport {

namespace detail {
class SampleIntake;
}

/// What a CAN link counts beyond LinkCounters (which it fills too, see CanLink).
struct CanLinkCounters {
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_received = 0;  ///< Data frames read, before validation (error frames not included).
  /// Every data frame read, by what became of it (kPending: stored into a cycle not yet complete).
  std::array<std::uint64_t, static_cast<std::size_t>(proto::can::FrameStatus::kCount)> frames_by_status{};
  std::uint64_t partial_cycles = 0;        ///< Cycles dropped because some of their frames never came.
  std::uint64_t resyncs = 0;               ///< Counter tracking restarted (peer restart or ≥ 8 cycles lost).
  std::uint64_t tx_saturated_fields = 0;   ///< Sent fields clamped to their range.
  std::uint64_t tx_non_finite_fields = 0;  ///< Sent fields that were NaN/inf (the peer drops those cycles).
  std::uint64_t tx_buffer_full = 0;
  std::uint64_t tx_refused_bus_off = 0;
  // Error frames, by class (one frame may count in several).
  std::uint64_t error_frames = 0;
  std::uint64_t bus_off = 0;
  std::uint64_t error_passive = 0;  ///< Controller reached error-passive (RX or TX).
  std::uint64_t error_warning = 0;  ///< Controller reached the warning level (RX or TX).
  std::uint64_t controller_overflow = 0;
  std::uint64_t protocol_errors = 0;  ///< Protocol violations and bus errors.
  std::uint64_t no_ack = 0;
  std::uint64_t tx_timeouts = 0;
  std::uint64_t lost_arbitration = 0;
  std::uint64_t transceiver = 0;
  std::uint64_t restarts = 0;
};

/// Link over CAN frames (docs/can.md): each Send splits the sample into the frames of one cycle
/// (proto/can/sample_codec.hpp); Poll drains the port, reassembles the peer's cycles, and hands them to the sample
/// intake every link shares (counting, sequence classification, newest wins), as the UDP link does.
///
/// LinkCounters semantics on CAN: `received` counts units with an outcome — a completed cycle, a rejected frame,
/// or a dropped partial cycle — so that received == accepted + superseded + reordered + duplicates + rejected
/// holds as for UDP; raw frame counts are in CanLinkCounters. CAN reasons map onto proto::DecodeStatus:
/// unknown_id → kBadMagic, bad_format → kBadType, bad_length → kBadLength, reserved_bits and duplicate_frame →
/// kOutOfRange, counter_mismatch → kBadCrc, non_finite → kNonFinite, partial cycle → kTooShort.
/// Error frames count in `bus_errors`. A bus-off is a link fault: bus_off() is true, Send refuses (send_errors),
/// until the controller reports a restart.
class CanLink final : public Link {
 public:
  /// Frames read per Poll at most (bounds the cycle's time; the rest waits for the next Poll).
  static constexpr int kMaxFramesPerPoll = 256;
  /// Completed cycles in a row that are stale/duplicate before the counter tracking restarts.
  static constexpr int kResyncAfter = 3;

  /// `format` must pass proto::can::CheckFormat (throws teleop::Error otherwise). `description` is appended to
  /// Describe() (e.g. the bus-load budget).
  CanLink(const proto::can::CanWireFormat& format, proto::SenderRole local_role, std::unique_ptr<CanPort> port,
          std::string description = "");
  ~CanLink() override;

  [[nodiscard]] bool Send(const proto::SampleMessage& message) noexcept override;
  [[nodiscard]] bool Poll(proto::SampleMessage& newest) noexcept override;
  /// The SYNC-like trigger of a triggered slave (docs/can.md, "Phase-locked cycles over CAN"): true as soon as
  /// the peer's *complete* sample of a cycle newer than any before has arrived — every frame of the cycle, which
  /// reassembly already requires, so the cycle's last frame plays CiA 301's SYNC role and no extra frame is sent.
  /// Reads and reassembles frames as they come (the port's WaitReadable between them) and keeps the completed
  /// sample for the next Poll(); a partial cycle, a rejected frame, a stale or repeated cycle and error frames do
  /// not fire it. False when the port's clock reaches `deadline_ns` first (a deadline already past: one look
  /// without waiting). Bounded: a flood of frames is read at most kMaxFramesPerPoll at a time and the deadline is
  /// checked after every batch. Real-time safe.
  [[nodiscard]] bool WaitReadable(std::int64_t deadline_ns) noexcept override;
  /// When the frame that completed the sample the last successful Poll() returned was received (the port's
  /// receive_time_ns(), e.g. the kernel's timestamp; the read time where the port has none).
  std::int64_t newest_receive_time_ns() const noexcept override { return newest_receive_time_ns_; }
  const LinkCounters& counters() const noexcept override { return counters_; }
  std::string Describe() const override;

  const CanLinkCounters& can_counters() const noexcept { return can_; }
  /// Link fault: the controller is bus-off (latched until it reports a restart).
  bool bus_off() const noexcept { return bus_off_; }
  bool faulted() const noexcept override { return bus_off_; }
  /// One line with the CAN-specific counters for the run summary.
  std::string Summary() const override;
  CanPort& port() noexcept { return *port_; }

 private:
  void HandleErrorFrame(const proto::can::CanFrame& frame) noexcept;
  void Reject(proto::DecodeStatus reason) noexcept;
  /// True when the cycle became the newest sample of the drain.
  bool OfferCycle(proto::SampleMessage& sample) noexcept;
  /// Reads up to kMaxFramesPerPoll frames into the assembler and the open drain.
  void Drain() noexcept;
  void OpenDrain() noexcept;
  void CountAbandoned() noexcept;

  proto::can::CanWireFormat format_;
  proto::SenderRole local_role_;
  std::unique_ptr<CanPort> port_;
  std::string description_;
  proto::can::CycleAssembler assembler_;
  std::unique_ptr<detail::SampleIntake> intake_;
  LinkCounters counters_{};
  CanLinkCounters can_{};
  std::array<proto::can::CanFrame, proto::can::kMaxSlots> tx_frames_{};
  proto::can::CanFrame rx_frame_{};
  proto::SampleMessage scratch_{};
  bool bus_off_ = false;
  /// A drain (intake Begin .. Finish) is open: WaitReadable has read frames that the next Poll hands back.
  bool drain_open_ = false;
  std::int64_t pending_receive_time_ns_ = 0;
  std::int64_t newest_receive_time_ns_ = 0;
  int consecutive_old_ = 0;
  std::uint64_t abandoned_seen_ = 0;
};

/// Opens a CAN link for a process of role `local_role` running at `rate_hz`: checks the identifiers and the bus-load
/// budget (throws teleop::Error with the numbers when above config.max_bus_load), then opens the medium
/// (SocketCAN or teleop-canbus). Throws teleop::Error on any set-up failure.
std::unique_ptr<Link> MakeCanLink(const CanLinkConfig& config, proto::SenderRole local_role, double rate_hz);

}  // namespace teleop::transport
