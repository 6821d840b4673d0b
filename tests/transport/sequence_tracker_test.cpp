#include "teleop/transport/sequence_tracker.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <set>
#include <vector>

#include "proto/property_count.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::transport {
namespace {

using Verdict = SequenceTracker::Verdict;

class SequenceTrackerTest : public ::testing::Test {
 protected:
  Verdict See(std::uint32_t s) { return tracker_.Observe(s, counters_); }
  SequenceTracker tracker_;
  LinkCounters counters_;
};

TEST_F(SequenceTrackerTest, InOrderCountsNothing) {
  for (std::uint32_t s = 10; s < 20; ++s) EXPECT_EQ(See(s), Verdict::kNewer);
  EXPECT_EQ(counters_.lost, 0u);
  EXPECT_EQ(counters_.reordered, 0u);
  EXPECT_EQ(counters_.duplicates, 0u);
  EXPECT_EQ(tracker_.newest(), 19u);
}

TEST_F(SequenceTrackerTest, GapCountsLoss) {
  EXPECT_EQ(See(1), Verdict::kNewer);
  EXPECT_EQ(See(2), Verdict::kNewer);
  EXPECT_EQ(See(5), Verdict::kNewer);
  EXPECT_EQ(counters_.lost, 2u);
}

TEST_F(SequenceTrackerTest, LateArrivalIsReorderedAndTakesBackItsLoss) {
  See(1);
  See(3);
  EXPECT_EQ(counters_.lost, 1u);
  EXPECT_EQ(See(2), Verdict::kStale);
  EXPECT_EQ(counters_.lost, 0u);
  EXPECT_EQ(counters_.reordered, 1u);
  EXPECT_EQ(tracker_.newest(), 3u);
  // The same late number again is a duplicate, not a second reorder.
  EXPECT_EQ(See(2), Verdict::kDuplicate);
  EXPECT_EQ(counters_.reordered, 1u);
  EXPECT_EQ(counters_.duplicates, 1u);
  EXPECT_EQ(counters_.lost, 0u);
}

TEST_F(SequenceTrackerTest, DuplicateOfNewestAndOfOlder) {
  See(7);
  EXPECT_EQ(See(7), Verdict::kDuplicate);
  See(8);
  EXPECT_EQ(See(7), Verdict::kDuplicate);
  EXPECT_EQ(counters_.duplicates, 2u);
  EXPECT_EQ(counters_.reordered, 0u);
}

TEST_F(SequenceTrackerTest, WrapsAt2To32) {
  EXPECT_EQ(See(0xFFFFFFFEu), Verdict::kNewer);
  EXPECT_EQ(See(0xFFFFFFFFu), Verdict::kNewer);
  EXPECT_EQ(See(0u), Verdict::kNewer);
  EXPECT_EQ(See(2u), Verdict::kNewer);  // 1 lost across nothing special
  EXPECT_EQ(counters_.lost, 1u);
  EXPECT_EQ(See(1u), Verdict::kStale);
  EXPECT_EQ(counters_.lost, 0u);
  EXPECT_EQ(See(0xFFFFFFFFu), Verdict::kDuplicate);  // older than the wrap, already seen
  EXPECT_EQ(tracker_.newest(), 2u);
}

TEST_F(SequenceTrackerTest, GapAcrossTheWrap) {
  See(0xFFFFFFF0u);
  EXPECT_EQ(See(0x0000000Fu), Verdict::kNewer);
  EXPECT_EQ(counters_.lost, 30u);  // 0xFFFFFFF1..0xFFFFFFFF (15) and 0..0xE (15)
  EXPECT_EQ(See(0xFFFFFFFAu), Verdict::kStale);
  EXPECT_EQ(counters_.lost, 29u);
}

TEST_F(SequenceTrackerTest, OlderThanTheWindowIsAPeerRestart) {
  See(100000);
  See(100001);
  // Just inside the window: stale.
  EXPECT_EQ(See(100001 - (SequenceTracker::kWindow - 1)), Verdict::kStale);
  // A restarted peer begins at 0 again: accepted, re-anchored, no loss invented.
  const std::uint64_t lost_before = counters_.lost;
  EXPECT_EQ(See(0), Verdict::kNewer);
  EXPECT_EQ(See(1), Verdict::kNewer);
  EXPECT_EQ(counters_.lost, lost_before);
  EXPECT_EQ(tracker_.newest(), 1u);
}

TEST_F(SequenceTrackerTest, LateArrivalFromBeforeTheFirstIsNotAnUncountedLoss) {
  See(100);
  EXPECT_EQ(See(99), Verdict::kStale);
  EXPECT_EQ(counters_.reordered, 1u);
  EXPECT_EQ(counters_.lost, 0u);  // not wrapped around to 2^64 - 1
  See(102);
  EXPECT_EQ(counters_.lost, 1u);
  EXPECT_EQ(See(98), Verdict::kStale);
  EXPECT_EQ(counters_.lost, 1u);  // 98 was never counted lost, 101 still is
}

TEST_F(SequenceTrackerTest, ResetForgets) {
  See(5);
  tracker_.Reset();
  EXPECT_FALSE(tracker_.has_any());
  EXPECT_EQ(See(2), Verdict::kNewer);
  EXPECT_EQ(counters_.lost, 0u);
}

// Seeded property against a set-based reference: a stream with drops, duplicates and local shuffles (displacement
// well inside the window), starting near the wrap. At the end, lost == numbers in [first, newest] never seen,
// reordered == late first arrivals, duplicates == repeats.
TEST(SequenceTrackerProperty, MatchesAReferenceModel) {
  // One case is a 1000-number stream: TELEOP_PROPERTY_COUNT counts numbers / 100 here (default 200 streams).
  const int count = std::max(1, test::PropertyCount(20000) / 100);
  std::mt19937_64 rng(42);
  for (int n = 0; n < count; ++n) {
    const std::uint32_t base = 0xFFFFFFFFu - static_cast<std::uint32_t>(rng() % 2000);
    const int length = 1000;
    std::vector<std::uint32_t> stream;
    for (int i = 0; i < length; ++i) {
      if (rng() % 10 == 0) continue;  // dropped
      stream.push_back(base + static_cast<std::uint32_t>(i));
      if (rng() % 20 == 0) stream.push_back(base + static_cast<std::uint32_t>(i));  // duplicated
    }
    for (std::size_t i = 0; i + 1 < stream.size(); ++i) {  // local swaps: displacement < 8
      if (rng() % 8 == 0) std::swap(stream[i], stream[i + 1 + rng() % std::min<std::size_t>(7, stream.size() - i - 1)]);
    }
    SequenceTracker tracker;
    LinkCounters counters;
    std::set<std::int64_t> seen;  // in unwrapped numbers
    std::int64_t newest = -1;
    std::uint64_t late = 0;
    std::uint64_t repeats = 0;
    const std::int64_t first = static_cast<std::uint32_t>(stream.front() - base);
    for (const std::uint32_t s : stream) {
      const std::int64_t u = static_cast<std::uint32_t>(s - base);  // 0..length-1, unwrapped
      const Verdict v = tracker.Observe(s, counters);
      if (seen.count(u) != 0) {
        ++repeats;
        ASSERT_EQ(v, Verdict::kDuplicate);
      } else if (u < newest) {
        ++late;
        ASSERT_EQ(v, Verdict::kStale);
      } else {
        ASSERT_EQ(v, Verdict::kNewer);
      }
      seen.insert(u);
      newest = std::max(newest, u);
    }
    std::uint64_t never_seen = 0;
    for (std::int64_t u = first; u <= newest; ++u) never_seen += seen.count(u) == 0 ? 1 : 0;
    ASSERT_EQ(counters.lost, never_seen) << "case " << n;
    ASSERT_EQ(counters.reordered, late);
    ASSERT_EQ(counters.duplicates, repeats);
  }
}

}  // namespace
}  // namespace teleop::transport
