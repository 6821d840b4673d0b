#include "teleop/runtime/latency_histogram.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "test_utilities/limit_malloc.hpp"

namespace teleop::runtime {
namespace {

// Nearest-rank percentile of a sorted array: the ceil(p·n)-th smallest value.
std::int64_t ReferencePercentile(const std::vector<std::int64_t>& sorted, double p) {
  if (p <= 0.0) return sorted.front();
  const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(sorted.size())));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

TEST(LatencyHistogram, EmptyReportsZero) {
  LatencyHistogram h;
  EXPECT_EQ(h.count(), 0u);
  EXPECT_EQ(h.Percentile(0.5), 0);
  EXPECT_EQ(h.min_ns(), 0);
  EXPECT_EQ(h.max_ns(), 0);
  EXPECT_EQ(h.mean_ns(), 0.0);
}

// Seeded randomized property test: against a sorted-array reference, every percentile is within one bin (1 µs)
// above the exact one and never below it. Raise kTrials to search harder.
TEST(LatencyHistogram, PercentilesMatchSortedReferenceWithinOneBin) {
  constexpr int kTrials = 40;
  std::mt19937_64 rng(20240611);
  for (int trial = 0; trial < kTrials; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 3000);
    // Mixture: a tight cluster around the period, a long tail, and a few samples in the overflow bin.
    std::normal_distribution<double> cluster(1.0e6, 3.0e3);
    std::exponential_distribution<double> tail(1.0 / 2.0e5);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    std::vector<std::int64_t> values;
    LatencyHistogram h;
    for (int i = 0; i < n; ++i) {
      const double u = uniform(rng);
      double v = u < 0.8 ? cluster(rng) : (u < 0.99 ? tail(rng) : 1.2e7 + 1.0e6 * uniform(rng));
      v = std::max(v, 0.0);
      const auto ns = static_cast<std::int64_t>(v);
      values.push_back(ns);
      h.Add(ns);
    }
    std::sort(values.begin(), values.end());
    ASSERT_EQ(h.count(), values.size());
    EXPECT_EQ(h.min_ns(), values.front());
    EXPECT_EQ(h.max_ns(), values.back());
    double sum = 0.0;
    for (auto v : values) sum += static_cast<double>(v);
    EXPECT_NEAR(h.mean_ns(), sum / static_cast<double>(n), 1e-6 * sum / n);

    for (double p : {0.0, 0.01, 0.1, 0.25, 0.5, 0.9, 0.95, 0.99, 0.999, 1.0}) {
      const std::int64_t exact = ReferencePercentile(values, p);
      const std::int64_t got = h.Percentile(p);
      SCOPED_TRACE(::testing::Message() << "trial " << trial << " n " << n << " p " << p);
      if (exact >= LatencyHistogram::kBins * LatencyHistogram::kBinWidthNs) {
        EXPECT_EQ(got, values.back()) << "overflow bin reports the exact max";
      } else {
        EXPECT_GE(got, exact);
        EXPECT_LT(got, exact + LatencyHistogram::kBinWidthNs);
        EXPECT_LE(got, values.back());
      }
    }
  }
}

TEST(LatencyHistogram, ExtremesAreExactAndNegativeClampsToZero) {
  LatencyHistogram h;
  h.Add(1'234'567);
  h.Add(-50);
  h.Add(999);
  EXPECT_EQ(h.Percentile(0.0), 0);
  EXPECT_EQ(h.Percentile(1.0), 1'234'567);
  EXPECT_EQ(h.Percentile(0.5), 1000);  // 999 ns is in bin [0, 1000): upper edge
  h.Add(50'000'000);
  EXPECT_EQ(h.overflow_count(), 1u);
  EXPECT_EQ(h.Percentile(1.0), 50'000'000);
  h.Reset();
  EXPECT_EQ(h.count(), 0u);
  EXPECT_EQ(h.Percentile(0.99), 0);
}

TEST(LatencyHistogram, AddDoesNotAllocate) {
  LatencyHistogram h;
  test::AllocationCounter counter;
  for (std::int64_t i = 0; i < 10000; ++i) h.Add(i * 997);
  EXPECT_EQ(h.Percentile(0.5) > 0, true);
  EXPECT_EQ(counter.count(), 0u);
}

}  // namespace
}  // namespace teleop::runtime
