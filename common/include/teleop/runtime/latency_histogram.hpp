#pragma once

#include <array>
#include <cstdint>

namespace teleop::runtime {

/// Fixed-size histogram of non-negative durations (ns) for percentiles without allocation: 1 µs bins up to
/// 10 ms, then a single overflow bin; exact min, max and mean are kept as well. Percentiles are bin upper edges
/// (resolution 1 µs), except that a percentile landing in the top sample returns the exact max.
class LatencyHistogram {
 public:
  static constexpr std::int64_t kBinWidthNs = 1000;
  static constexpr int kBins = 10000;

  void Add(std::int64_t value_ns) noexcept;
  void Reset() noexcept;
  std::uint64_t count() const noexcept { return count_; }
  std::int64_t min_ns() const noexcept { return count_ ? min_ns_ : 0; }
  std::int64_t max_ns() const noexcept { return count_ ? max_ns_ : 0; }
  double mean_ns() const noexcept { return count_ ? sum_ns_ / static_cast<double>(count_) : 0.0; }
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
