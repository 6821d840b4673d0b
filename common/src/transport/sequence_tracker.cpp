#include "teleop/transport/sequence_tracker.hpp"

#include "teleop/transport/link.hpp"

namespace teleop::transport {

void SequenceTracker::Reset() noexcept {
  has_any_ = false;
  newest_ = 0;
  anchor_ = 0;
  seen_.fill(0);
}

bool SequenceTracker::Seen(std::uint32_t sequence) const noexcept {
  const std::uint32_t bit = sequence % kWindow;
  return ((seen_[bit / 64] >> (bit % 64)) & 1u) != 0;
}

void SequenceTracker::Mark(std::uint32_t sequence, bool seen) noexcept {
  const std::uint32_t bit = sequence % kWindow;
  const std::uint64_t mask = std::uint64_t{1} << (bit % 64);
  if (seen) {
    seen_[bit / 64] |= mask;
  } else {
    seen_[bit / 64] &= ~mask;
  }
}

SequenceTracker::Verdict SequenceTracker::Observe(std::uint32_t sequence, LinkCounters& counters) noexcept {
  // Unsigned differences are exact modulo 2^32; "ahead" means less than half the circle forward.
  const std::uint32_t ahead = sequence - newest_;
  const std::uint32_t behind = newest_ - sequence;
  const bool restart = has_any_ && ahead >= 0x80000000u && behind >= kWindow;
  if (!has_any_ || restart) {
    Reset();
    has_any_ = true;
    newest_ = sequence;
    anchor_ = sequence;
    Mark(sequence, true);
    return Verdict::kNewer;
  }
  if (ahead == 0) {
    ++counters.duplicates;
    return Verdict::kDuplicate;
  }
  if (ahead < 0x80000000u) {
    counters.lost += ahead - 1;
    if (ahead >= kWindow) {
      seen_.fill(0);
    } else {
      for (std::uint32_t s = newest_ + 1; s != sequence; ++s) Mark(s, false);
    }
    Mark(sequence, true);
    newest_ = sequence;
    return Verdict::kNewer;
  }
  // Behind the newest by less than kWindow.
  if (Seen(sequence)) {
    ++counters.duplicates;
    return Verdict::kDuplicate;
  }
  Mark(sequence, true);
  ++counters.reordered;
  const std::uint32_t anchor_behind = newest_ - anchor_;
  const bool before_anchor = anchor_behind < kWindow && behind > anchor_behind;
  if (!before_anchor && counters.lost > 0) --counters.lost;
  return Verdict::kStale;
}

}  // namespace teleop::transport
