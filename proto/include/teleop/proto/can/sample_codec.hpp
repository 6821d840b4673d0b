#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "teleop/proto/can/can_frame.hpp"
#include "teleop/proto/can/frame_layout.hpp"
#include "teleop/proto/can/wire_format.hpp"
#include "teleop/proto/sample_message.hpp"

namespace teleop::proto::can {

/// What encoding one cycle did.
struct EncodeResult {
  int frames = 0;      ///< Frames written to `out` (0: format invalid, dof mismatch or `out` too small).
  int saturated = 0;   ///< Fields clamped to their range (sent as the largest code, never wrapped).
  int non_finite = 0;  ///< Fields that were NaN/inf (sent as the "not a number" code: the receiver drops the cycle).
};

/// Splits one sample into the frames of its cycle (see frame_layout.hpp). The counter is sequence mod 16, the
/// identifiers are those of message.sender. message.dof must equal format.dof. Flag bits 0..6 are carried (bit 6
/// kFlagClutched); bit 7 (reserved) and the time stamps are not. Pure, no allocation.
[[nodiscard]] EncodeResult EncodeCycle(const SampleMessage& message, const CanWireFormat& format,
                                       std::span<CanFrame> out) noexcept;

/// Quantizes one value: round to the nearest LSB, clamp to ±(2^(n-1) - 1); NaN/inf → -2^(n-1). `saturated` is set
/// when clamped.
std::int32_t Quantize(double value, const FieldScaling& scaling, bool& saturated) noexcept;

/// What became of one received frame.
enum class FrameStatus : std::uint8_t {
  kPending = 0,      ///< Stored; its cycle is not complete yet.
  kComplete,         ///< Completed a cycle: the sample was written.
  kUnknownId,        ///< Identifier is not one of the peer's (or a 29/11-bit mismatch).
  kBadFormat,        ///< Remote frame, error frame, or FD where classic is configured (or vice versa).
  kBadLength,        ///< Data length is not what the configured DOF count needs for this slot.
  kReservedBits,     ///< A reserved bit or FD padding byte is not 0.
  kDuplicateFrame,   ///< This slot of this cycle was already received.
  kNonFinite,        ///< The completed cycle carries a "not a number" code: dropped.
  kCounterMismatch,  ///< The slots of one FD frame carry different counters.
  kOldLayout,        ///< A frame of CAN layout 1 (before kFlagClutched crossed CAN): slot 0 without the layout
                     ///< marker, or a 1-DOF slot 0 of layout 1's 6 bytes. The peer runs an older build.
  kCount,
};
const char* ToString(FrameStatus status) noexcept;

/// Reassembles the peer's cycles from its frames. Frames of up to kAssemblies cycles may be in flight at once (a
/// controller with several transmit mailboxes sends the lowest identifier first, so slot 0 of cycle n+1 can
/// overtake slot 1 of cycle n); a cycle is decoded only when all of its slots carry the same counter, so a sample
/// never mixes two cycles. When a new cycle needs a buffer and all are in use, the oldest partial cycle is
/// dropped (counted in abandoned_partial_cycles()). Pure, no allocation.
class CycleAssembler {
 public:
  static constexpr int kAssemblies = 4;

  CycleAssembler(const CanWireFormat& format, SenderRole peer) noexcept;

  /// Feeds one frame. On kComplete `out` holds the sample: sender = peer, dof, flags, fields, sequence = the 4-bit
  /// counter (the caller extends it, see ExtendCounter), time stamps 0. Otherwise `out` is untouched.
  [[nodiscard]] FrameStatus Push(const CanFrame& frame, SampleMessage& out) noexcept;

  /// Partial cycles dropped so far (an older cycle's slots never all arrived).
  std::uint64_t abandoned_partial_cycles() const noexcept { return abandoned_; }
  /// Cycles currently waiting for slots.
  int partial_cycles() const noexcept;
  /// Forgets every partial cycle (counted as abandoned).
  void Reset() noexcept;
  /// Call once per receive poll (after draining). A partial cycle untouched for kExpiryTicks polls is dropped
  /// (counted as abandoned): the peer moved on or paused, and waiting longer would let its 4-bit counter come round
  /// so that a later cycle's frame could complete it.
  void Tick() noexcept;
  static constexpr std::uint64_t kExpiryTicks = 4;

 private:
  struct Assembly {
    bool in_use = false;
    std::uint8_t counter = 0;
    std::uint8_t received_mask = 0;
    std::uint64_t age = 0;
    std::uint64_t touched_tick = 0;
    std::array<std::uint64_t, kMaxSlots> slot_bits{};
  };
  FrameStatus PushClassic(const CanFrame& frame, SampleMessage& out) noexcept;
  FrameStatus PushFd(const CanFrame& frame, SampleMessage& out) noexcept;
  FrameStatus Decode(const std::array<std::uint64_t, kMaxSlots>& slots, SampleMessage& out) const noexcept;

  CanWireFormat format_;
  SenderRole peer_;
  std::uint32_t base_id_;
  int slots_;
  std::uint8_t all_slots_mask_;
  std::array<std::uint64_t, kMaxSlots> reserved_mask_{};  ///< Bits of each slot that must be 0.
  std::array<Assembly, kAssemblies> assemblies_{};
  std::uint64_t next_age_ = 0;
  std::uint64_t tick_ = 0;
  std::uint64_t abandoned_ = 0;
};

/// The 32-bit sequence nearest to `reference` (within -8..+7) whose low 4 bits are `counter`: turns the wire
/// counter back into a sequence number the SequenceTracker can classify.
std::uint32_t ExtendCounter(std::uint32_t reference, std::uint8_t counter) noexcept;

}  // namespace teleop::proto::can
