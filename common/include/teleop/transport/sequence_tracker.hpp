#pragma once

#include <array>
#include <cstdint>

namespace teleop::transport {

struct LinkCounters;

/// Tracks sequence numbers of accepted samples: loss, reordering, duplicates (libfranka-style "keep the newest").
/// Wrap-around safe: serial-number arithmetic on uint32 (RFC 1982), so 0 follows 0xFFFFFFFF.
///
/// - newer by d:   kNewer; the d - 1 numbers skipped are counted lost.
/// - equal:        kDuplicate.
/// - older by < kWindow: a number never seen is a late arrival: kStale, counted reordered, and the loss counted
///   for it is taken back; a number already seen is kDuplicate.
/// - older by ≥ kWindow: taken as a restart of the peer (its sequence began again): kNewer, re-anchored there,
///   nothing counted lost. Late arrivals from before the first number seen are counted reordered only.
///   No real network delays a datagram kWindow cycles (64 ms at 4 kHz).
class SequenceTracker {
 public:
  /// Numbers remembered behind the newest (for reorder vs duplicate, and for the restart rule).
  static constexpr std::uint32_t kWindow = 256;

  enum class Verdict : std::uint8_t { kNewer, kDuplicate, kStale };
  /// Classifies `sequence` and updates the counters in `counters` (lost / reordered / duplicates).
  Verdict Observe(std::uint32_t sequence, LinkCounters& counters) noexcept;
  bool has_any() const noexcept { return has_any_; }
  std::uint32_t newest() const noexcept { return newest_; }
  /// Forgets everything: the next number observed is accepted as the first.
  void Reset() noexcept;

 private:
  bool Seen(std::uint32_t sequence) const noexcept;
  void Mark(std::uint32_t sequence, bool seen) noexcept;

  bool has_any_ = false;
  std::uint32_t newest_ = 0;
  std::uint32_t anchor_ = 0;  ///< First number after Reset or a restart: older ones were never counted lost.
  /// Bit (s % kWindow) set: number s, within kWindow of newest_, has been received.
  std::array<std::uint64_t, kWindow / 64> seen_{};
};

}  // namespace teleop::transport
