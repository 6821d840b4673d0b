#include "teleop/runtime/watchdog.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::runtime {
namespace {

// Times are binary-exact (multiples of 1/16 s) so "age == timeout" is exactly representable.
constexpr double kTimeout = 0.0625;

TEST(LinkWatchdog, WaitsForTheFirstSampleWithoutTripping) {
  LinkWatchdog w(kTimeout);
  EXPECT_EQ(w.state(), LinkWatchdog::State::kWaiting);
  EXPECT_FALSE(w.Fresh(0.0));
  EXPECT_FALSE(w.Fresh(100.0));
  EXPECT_EQ(w.trips(), 0u);
  EXPECT_FALSE(w.peer_valid());
  EXPECT_FALSE(w.expired());
  EXPECT_TRUE(std::isinf(w.AgeS(1.0)));
}

TEST(LinkWatchdog, TripsAfterTheTimeoutAndRecoversOnTheNextSample) {
  LinkWatchdog w(kTimeout);
  w.Feed(1.0);
  EXPECT_TRUE(w.Fresh(1.0));
  EXPECT_TRUE(w.Fresh(1.0 + kTimeout)) << "age == timeout is still fresh";
  EXPECT_DOUBLE_EQ(w.AgeS(1.0 + kTimeout), kTimeout);
  EXPECT_EQ(w.recoveries(), 0u) << "the first sample is not a recovery";

  EXPECT_FALSE(w.Fresh(1.0 + kTimeout + 1.0 / 1024));
  EXPECT_TRUE(w.expired());
  EXPECT_EQ(w.trips(), 1u);
  EXPECT_FALSE(w.Fresh(2.0));
  EXPECT_EQ(w.trips(), 1u) << "one trip per expiry, not per cycle";

  w.Feed(2.0);
  EXPECT_EQ(w.recoveries(), 1u);
  EXPECT_TRUE(w.Fresh(2.0 + 1.0 / 16));
  EXPECT_TRUE(w.peer_valid());

  // Second outage.
  EXPECT_FALSE(w.Fresh(3.0));
  w.Feed(3.5);
  EXPECT_EQ(w.trips(), 2u);
  EXPECT_EQ(w.recoveries(), 2u);
  EXPECT_EQ(w.feeds(), 3u);
}

TEST(LinkWatchdog, ExpiredStaysExpiredUntilFedEvenIfAskedEarlier) {
  LinkWatchdog w(kTimeout);
  w.Feed(1.0);
  EXPECT_FALSE(w.Fresh(2.0));
  EXPECT_FALSE(w.Fresh(1.0)) << "an expired link needs a new sample, not an earlier clock";
}

TEST(LinkWatchdog, NonFiniteTimesAreSafe) {
  LinkWatchdog w(kTimeout);
  w.Feed(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(w.rejected_times(), 1u);
  EXPECT_EQ(w.state(), LinkWatchdog::State::kWaiting);
  w.Feed(1.0);
  EXPECT_FALSE(w.Fresh(std::numeric_limits<double>::quiet_NaN())) << "NaN now reads as expired";
  EXPECT_EQ(w.trips(), 1u);
}

TEST(LinkWatchdog, ResetGoesBackToWaitingAndKeepsCounters) {
  LinkWatchdog w(kTimeout);
  w.Feed(1.0);
  EXPECT_FALSE(w.Fresh(5.0));
  w.Reset();
  EXPECT_EQ(w.state(), LinkWatchdog::State::kWaiting);
  EXPECT_EQ(w.trips(), 1u);
  w.Feed(6.0);
  EXPECT_EQ(w.recoveries(), 0u) << "after Reset the next sample is a first sample";
}

TEST(LinkWatchdog, RejectsBadTimeout) {
  EXPECT_THROW(LinkWatchdog(0.0), Error);
  EXPECT_THROW(LinkWatchdog(-0.05), Error);
  EXPECT_THROW(LinkWatchdog{std::numeric_limits<double>::quiet_NaN()}, Error);
  EXPECT_THROW(LinkWatchdog{std::numeric_limits<double>::infinity()}, Error);
}

TEST(LinkWatchdog, DoesNotAllocate) {
  LinkWatchdog w(kTimeout);
  test::AllocationCounter counter;
  bool any = false;
  for (int i = 0; i < 1000; ++i) {
    if (i % 7 != 0) w.Feed(i * 1e-3);
    any |= w.Fresh(i * 1e-3);
  }
  EXPECT_TRUE(any);
  EXPECT_EQ(counter.count(), 0u);
}

}  // namespace
}  // namespace teleop::runtime
