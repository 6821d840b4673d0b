#include "teleop/runtime/spsc_ring.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

#include "test_utilities/limit_malloc.hpp"

namespace teleop::runtime {
namespace {

struct Item {
  std::uint64_t sequence;
  double payload;
};

TEST(SpscRing, SingleThreadFifoAndCapacity) {
  SpscRing<Item> ring(4);
  EXPECT_EQ(ring.capacity(), 4u);
  for (std::uint64_t i = 0; i < 4; ++i) EXPECT_TRUE(ring.TryPush({i, 0.5 * static_cast<double>(i)}));
  EXPECT_FALSE(ring.TryPush({99, 0.0})) << "a full ring refuses";
  Item out{};
  for (std::uint64_t i = 0; i < 4; ++i) {
    ASSERT_TRUE(ring.TryPop(out));
    EXPECT_EQ(out.sequence, i);
    EXPECT_EQ(out.payload, 0.5 * static_cast<double>(i));
  }
  EXPECT_FALSE(ring.TryPop(out)) << "empty";
}

TEST(SpscRing, PushAndPopDoNotAllocate) {
  SpscRing<Item> ring(8);
  Item out{};
  test::AllocationCounter counter;
  for (std::uint64_t i = 0; i < 100; ++i) {
    EXPECT_TRUE(ring.TryPush({i, 0.0}));
    EXPECT_TRUE(ring.TryPop(out));
  }
  EXPECT_EQ(counter.count(), 0u);
}

// Two threads, capacity large enough for everything: every item arrives, in order, none duplicated.
TEST(SpscRing, TwoThreadsKeepOrderAndLoseNothingWhenCapacitySuffices) {
  constexpr std::uint64_t kItems = 200'000;
  SpscRing<Item> ring(kItems);
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kItems; ++i) {
      ASSERT_TRUE(ring.TryPush({i, static_cast<double>(i) * 1e-3}));
    }
  });
  std::uint64_t expected = 0;
  Item out{};
  while (expected < kItems) {
    if (ring.TryPop(out)) {
      ASSERT_EQ(out.sequence, expected);
      ASSERT_EQ(out.payload, static_cast<double>(expected) * 1e-3);
      ++expected;
    }
  }
  producer.join();
  EXPECT_EQ(expected, kItems);
  EXPECT_FALSE(ring.TryPop(out));
}

// Two threads, a small ring and a slow consumer: the producer never blocks; what it could not push is counted, and
// pushed + dropped == offered, consumed == pushed, with order kept among the survivors.
TEST(SpscRing, TwoThreadsCountDropsWhenFull) {
  constexpr std::uint64_t kItems = 100'000;
  SpscRing<Item> ring(64);
  std::uint64_t pushed = 0;
  std::uint64_t dropped = 0;
  std::atomic<bool> done{false};
  std::atomic<bool> consumer_may_start{false};
  std::thread producer([&] {
    for (std::uint64_t i = 0; i < kItems; ++i) {
      if (ring.TryPush({i, 0.0})) {
        ++pushed;
      } else {
        ++dropped;
      }
      // The consumer starts only after 1000 offers, so at least 1000 - 64 drops are certain.
      if (i == 999) consumer_may_start.store(true, std::memory_order_release);
    }
    done.store(true, std::memory_order_release);
  });
  while (!consumer_may_start.load(std::memory_order_acquire)) std::this_thread::yield();
  std::uint64_t consumed = 0;
  std::int64_t last = -1;
  Item out{};
  while (true) {
    const bool finished = done.load(std::memory_order_acquire);
    while (ring.TryPop(out)) {
      ASSERT_GT(static_cast<std::int64_t>(out.sequence), last) << "order kept";
      last = static_cast<std::int64_t>(out.sequence);
      ++consumed;
    }
    if (finished) break;
    std::this_thread::yield();
  }
  producer.join();
  EXPECT_EQ(pushed + dropped, kItems);
  EXPECT_EQ(consumed, pushed);
  EXPECT_GE(dropped, 1000u - 64u);
}

}  // namespace
}  // namespace teleop::runtime
