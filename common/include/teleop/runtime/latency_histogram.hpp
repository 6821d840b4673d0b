#pragma once

#include <array>
#include <cstdint>

namespace teleop::runtime {

/// Fixed-size histogram of non-negative durations (ns) for percentiles without allocation: 1 µs bins up to
/// 10 ms, then a single overflow bin; exact min, max and mean are kept as well. Percentiles are nearest-rank
/// (the ceil(p·n)-th smallest sample) reported as the upper edge of its bin, so a percentile is at most 1 µs above
/// the true one and never below it; it is clamped to the exact max, and p ≤ 0 gives the exact min. A percentile
/// landing in the overflow bin or on the top sample returns the exact max.
///
/// Add() is O(1), allocation-free and noexcept: safe in the control cycle. Not thread-safe: one writer, read it
/// from the same thread or after the writer stopped. Bin counts are 32-bit: at 4 kHz a single bin can take
/// twelve days of samples.
class LatencyHistogram {
 public:
  static constexpr std::int64_t kBinWidthNs = 1000;
  static constexpr int kBins = 10000;

  /// Records one duration; negative values count as 0.
  void Add(std::int64_t value_ns) noexcept;
  void Reset() noexcept;
  std::uint64_t count() const noexcept { return count_; }
  std::int64_t min_ns() const noexcept { return count_ ? min_ns_ : 0; }
  std::int64_t max_ns() const noexcept { return count_ ? max_ns_ : 0; }
  double mean_ns() const noexcept { return count_ ? sum_ns_ / static_cast<double>(count_) : 0.0; }
  /// Samples that fell past the last bin (≥ kBins · kBinWidthNs = 10 ms).
  std::uint64_t overflow_count() const noexcept { return bins_[kBins]; }
  /// p in [0, 1]. 0 when empty.
  std::int64_t Percentile(double p) const noexcept;

 private:
  std::array<std::uint32_t, kBins + 1> bins_{};
  std::uint64_t count_ = 0;
  std::int64_t min_ns_ = 0;
  std::int64_t max_ns_ = 0;
  double sum_ns_ = 0.0;
};

}  // namespace teleop::runtime
