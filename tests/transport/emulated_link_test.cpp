#include "teleop/transport/emulated_link.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"
#include "transport/link_test_helpers.hpp"

namespace teleop::transport {
namespace {

using proto::DecodeStatus;
using proto::SenderRole;
using test::MakeSample;

constexpr double kPeriod_s = 0.001;

// One cycle of a one-way stream master -> slave: send, advance the clock one period, poll.
struct OneWayRun {
  explicit OneWayRun(const EmulatedLinkConfig& config, std::uint64_t seed = 7)
      : pair(MakeEmulatedLinkPair(EmulatedMediumConfig{config, EmulatedLinkConfig{}, seed})) {}
  void Run(int cycles) {
    proto::SampleMessage got;
    for (int i = 0; i < cycles; ++i) {
      (void)pair.master->Send(MakeSample(SenderRole::kMaster, next++));
      pair.medium->Advance(kPeriod_s);
      if (pair.slave->Poll(got)) ++polls_with_news;
    }
    // Let everything in flight arrive.
    pair.medium->Advance(1.0);
    if (pair.slave->Poll(got)) ++polls_with_news;
  }
  const LinkCounters& rx() const { return pair.slave->counters(); }
  const EmulatedMedium::DirectionStats& stats() const { return pair.medium->stats(SenderRole::kMaster); }

  EmulatedLinkPair pair;
  std::uint32_t next = 1;
  int polls_with_news = 0;
};

// |observed/n - p| within 4.5 binomial standard deviations (the seed is fixed, so this cannot flake; the band
// says how far from the configured probability a correct channel may land).
void ExpectRate(std::uint64_t observed, std::uint64_t n, double p) {
  const double sigma = std::sqrt(p * (1.0 - p) / static_cast<double>(n));
  EXPECT_NEAR(static_cast<double>(observed) / static_cast<double>(n), p, 4.5 * sigma) << observed << " of " << n;
}

TEST(EmulatedLink, DeliversAfterTheConfiguredDelayOfSimulatedTime) {
  EmulatedLinkConfig config;
  config.delay_s = 0.0025;
  EmulatedLinkPair pair = MakeEmulatedLinkPair(config);
  ASSERT_TRUE(pair.master->Send(MakeSample(SenderRole::kMaster, 5)));
  proto::SampleMessage got;
  EXPECT_FALSE(pair.slave->Poll(got));  // t = 0
  pair.medium->Advance(0.001);
  EXPECT_FALSE(pair.slave->Poll(got));  // t = 1 ms
  pair.medium->Advance(0.001);
  EXPECT_FALSE(pair.slave->Poll(got));  // t = 2 ms
  pair.medium->Advance(0.001);
  ASSERT_TRUE(pair.slave->Poll(got));  // t = 3 ms ≥ 2.5 ms
  EXPECT_EQ(got.sequence, 5u);
  EXPECT_DOUBLE_EQ(pair.medium->now_s(), 0.003);
  EXPECT_FALSE(pair.master->Poll(got));  // nothing went the other way
}

TEST(EmulatedLink, ZeroDelayIsVisibleToThePeersNextPoll) {
  EmulatedLinkPair pair = MakeEmulatedLinkPair(EmulatedLinkConfig{});
  ASSERT_TRUE(pair.slave->Send(MakeSample(SenderRole::kSlave, 1)));
  proto::SampleMessage got;
  ASSERT_TRUE(pair.master->Poll(got));
  EXPECT_EQ(got.sender, SenderRole::kSlave);
}

TEST(EmulatedLink, IdealChannelDeliversEverythingInOrder) {
  EmulatedLinkConfig config;
  config.delay_s = 0.002;
  OneWayRun run(config);
  run.Run(1000);
  EXPECT_EQ(run.rx().accepted, 1000u);
  EXPECT_EQ(run.rx().lost + run.rx().reordered + run.rx().duplicates + run.rx().rejected, 0u);
  test::ExpectCountersBalance(run.rx());
}

constexpr int kStatCycles = 20000;

TEST(EmulatedLink, LossMatchesTheConfiguredProbability) {
  EmulatedLinkConfig config;
  config.delay_s = 0.002;
  config.loss_probability = 0.1;
  OneWayRun run(config);
  run.Run(kStatCycles);
  ExpectRate(run.stats().dropped, kStatCycles, 0.1);
  // The receiver sees every drop as a gap, except drops before the first or after the last arrival.
  EXPECT_LE(run.rx().lost, run.stats().dropped);
  EXPECT_GE(run.rx().lost + 6, run.stats().dropped);
  EXPECT_EQ(run.rx().received, kStatCycles - run.stats().dropped);
  test::ExpectCountersBalance(run.rx());
}

TEST(EmulatedLink, DuplicationMatchesTheConfiguredProbability) {
  EmulatedLinkConfig config;
  config.delay_s = 0.002;
  config.duplicate_probability = 0.05;
  OneWayRun run(config);
  run.Run(kStatCycles);
  ExpectRate(run.stats().duplicated, kStatCycles, 0.05);
  EXPECT_EQ(run.rx().duplicates, run.stats().duplicated);
  EXPECT_EQ(run.rx().accepted, static_cast<std::uint64_t>(kStatCycles));
  EXPECT_EQ(run.rx().lost, 0u);
  test::ExpectCountersBalance(run.rx());
}

TEST(EmulatedLink, ReorderingMatchesTheConfiguredProbability) {
  EmulatedLinkConfig config;
  config.delay_s = 0.003;  // > the 1 ms send interval, so the predecessor is still in flight
  config.reorder_probability = 0.05;
  OneWayRun run(config);
  run.Run(kStatCycles);
  ExpectRate(run.stats().reordered, kStatCycles, 0.05);
  EXPECT_EQ(run.rx().reordered, run.stats().reordered);
  EXPECT_EQ(run.rx().lost, 0u);  // every loss counted at the overtaking was taken back at the late arrival
  test::ExpectCountersBalance(run.rx());
}

TEST(EmulatedLink, CorruptionIsRejectedByTheRealDecoder) {
  EmulatedLinkConfig config;
  config.delay_s = 0.001;
  config.corrupt_probability = 0.02;
  OneWayRun run(config);
  run.Run(kStatCycles);
  ExpectRate(run.stats().corrupted, kStatCycles, 0.02);
  EXPECT_EQ(run.rx().rejected, run.stats().corrupted);
  EXPECT_EQ(run.rx().wrong_sender, 0u);
  EXPECT_GT(test::Rejected(run.rx(), DecodeStatus::kBadCrc), run.rx().rejected / 2);
  // A corrupted datagram is a missing number to the tracker.
  EXPECT_LE(run.rx().lost, run.stats().corrupted);
  test::ExpectCountersBalance(run.rx());
}

TEST(EmulatedLink, AllImpairmentsTogetherAreDeterministicForASeed) {
  EmulatedLinkConfig config;
  config.delay_s = 0.004;
  config.loss_probability = 0.05;
  config.duplicate_probability = 0.05;
  config.reorder_probability = 0.05;
  config.corrupt_probability = 0.05;
  OneWayRun a(config, 123);
  OneWayRun b(config, 123);
  OneWayRun c(config, 124);
  a.Run(5000);
  b.Run(5000);
  c.Run(5000);
  EXPECT_EQ(a.rx().accepted, b.rx().accepted);
  EXPECT_EQ(a.rx().lost, b.rx().lost);
  EXPECT_EQ(a.rx().reordered, b.rx().reordered);
  EXPECT_EQ(a.rx().duplicates, b.rx().duplicates);
  EXPECT_EQ(a.rx().rejected, b.rx().rejected);
  EXPECT_NE(a.stats().dropped + 1000 * a.stats().corrupted, c.stats().dropped + 1000 * c.stats().corrupted);
  test::ExpectCountersBalance(a.rx());
  EXPECT_GT(a.rx().reordered, 0u);
  EXPECT_GT(a.rx().duplicates, 0u);
  EXPECT_GT(a.rx().rejected, 0u);
}

TEST(EmulatedLink, WrongRoleIsRejectedLikeOnUdp) {
  EmulatedLinkPair pair = MakeEmulatedLinkPair(EmulatedLinkConfig{});
  ASSERT_TRUE(pair.master->Send(MakeSample(SenderRole::kSlave, 1)));
  proto::SampleMessage got;
  EXPECT_FALSE(pair.slave->Poll(got));
  EXPECT_EQ(pair.slave->counters().wrong_sender, 1u);
}

TEST(EmulatedLink, FullChannelRefusesSends) {
  EmulatedLinkConfig config;
  config.delay_s = 1.0;
  config.capacity = 4;
  EmulatedLinkPair pair = MakeEmulatedLinkPair(config);
  int refused = 0;
  for (std::uint32_t s = 1; s <= 6; ++s) refused += pair.master->Send(MakeSample(SenderRole::kMaster, s)) ? 0 : 1;
  EXPECT_EQ(refused, 2);
  EXPECT_EQ(pair.master->counters().send_errors, 2u);
  EXPECT_EQ(pair.medium->stats(SenderRole::kMaster).overflowed, 2u);
}

TEST(EmulatedLink, SendPollAndAdvanceDoNotAllocate) {
  EmulatedLinkConfig config;
  config.delay_s = 0.003;
  config.loss_probability = 0.1;
  config.duplicate_probability = 0.1;
  config.reorder_probability = 0.1;
  config.corrupt_probability = 0.1;
  EmulatedLinkPair pair = MakeEmulatedLinkPair(config);
  proto::SampleMessage got;
  std::uint64_t allocations = 0;
  {
    teleop::test::AllocationCounter counter;
    for (std::uint32_t s = 1; s < 2000; ++s) {
      (void)pair.master->Send(MakeSample(SenderRole::kMaster, s));
      (void)pair.slave->Send(MakeSample(SenderRole::kSlave, s));
      pair.medium->Advance(kPeriod_s);
      (void)pair.slave->Poll(got);
      (void)pair.master->Poll(got);
    }
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_GT(pair.slave->counters().accepted, 1000u);
  EXPECT_GT(pair.master->counters().accepted, 1000u);
}

TEST(EmulatedLink, BadConfigurationIsASetUpError) {
  EmulatedLinkConfig config;
  config.loss_probability = 1.5;
  EXPECT_THROW((void)MakeEmulatedLinkPair(config), Error);
  config = EmulatedLinkConfig{};
  config.delay_s = -0.001;
  EXPECT_THROW((void)MakeEmulatedLinkPair(config), Error);
  config = EmulatedLinkConfig{};
  config.corrupt_probability = std::nan("");
  EXPECT_THROW((void)MakeEmulatedLinkPair(config), Error);
  config = EmulatedLinkConfig{};
  config.capacity = 0;
  EXPECT_THROW((void)MakeEmulatedLinkPair(config), Error);
}

TEST(EmulatedLink, DescribeSaysWhatItEmulates) {
  EmulatedLinkConfig config;
  config.delay_s = 0.002;
  config.loss_probability = 0.25;
  EmulatedLinkPair pair = MakeEmulatedLinkPair(config, 9);
  EXPECT_EQ(pair.master->Describe(),
            "emulated master->slave (delay 2.000 ms, loss 0.250, dup 0.000, reorder 0.000, corrupt 0.000, seed 9)");
}

}  // namespace
}  // namespace teleop::transport
