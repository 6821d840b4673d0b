#include "teleop/runtime/latency_histogram.hpp"

#include <algorithm>
#include <cmath>

namespace teleop::runtime {

void LatencyHistogram::Add(std::int64_t value_ns) noexcept {
  const std::int64_t value = std::max<std::int64_t>(value_ns, 0);
  const std::int64_t bin = std::min<std::int64_t>(value / kBinWidthNs, kBins);
  ++bins_[static_cast<std::size_t>(bin)];
  if (count_ == 0) {
    min_ns_ = value;
    max_ns_ = value;
  } else {
    min_ns_ = std::min(min_ns_, value);
    max_ns_ = std::max(max_ns_, value);
  }
  ++count_;
  sum_ns_ += static_cast<double>(value);
}

void LatencyHistogram::Reset() noexcept {
  bins_.fill(0);
  count_ = 0;
  min_ns_ = 0;
  max_ns_ = 0;
  sum_ns_ = 0.0;
}

std::int64_t LatencyHistogram::Percentile(double p) const noexcept {
  if (count_ == 0) return 0;
  if (!(p > 0.0)) return min_ns_;  // also NaN
  if (p >= 1.0) return max_ns_;
  // Nearest rank: the k-th smallest sample, 1-based.
  const auto rank =
      std::clamp<std::uint64_t>(static_cast<std::uint64_t>(std::ceil(p * static_cast<double>(count_))), 1, count_);
  if (rank == count_) return max_ns_;
  std::uint64_t cumulative = 0;
  for (int bin = 0; bin < kBins; ++bin) {
    cumulative += bins_[static_cast<std::size_t>(bin)];
    if (cumulative >= rank) return std::min<std::int64_t>((bin + 1) * kBinWidthNs, max_ns_);
  }
  return max_ns_;  // in the overflow bin
}

}  // namespace teleop::runtime
