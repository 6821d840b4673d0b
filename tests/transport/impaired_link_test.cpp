// The shared impairment model (bursts, jitter, outages, bandwidth, seeding) and ImpairedLink, the receive-side
// wrapper that `link.emulate` puts around a process's link. The older impairments (loss, duplication,
// reordering, corruption) are also covered through EmulatedMedium in emulated_link_test.cpp.
#include "teleop/transport/impaired_link.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "teleop/error.hpp"
#include "teleop/transport/emulated_link.hpp"
#include "test_utilities/limit_malloc.hpp"
#include "transport/link_test_helpers.hpp"

namespace teleop::transport {
namespace {

using proto::SenderRole;
using test::MakeSample;

constexpr std::int64_t kPeriodNs = 1'000'000;  // 1 kHz

// |observed/n - p| within 4.5 binomial standard deviations (fixed seeds: cannot flake).
void ExpectRate(std::uint64_t observed, std::uint64_t n, double p) {
  const double sigma = std::sqrt(p * (1.0 - p) / static_cast<double>(n));
  EXPECT_NEAR(static_cast<double>(observed) / static_cast<double>(n), p, 4.5 * sigma) << observed << " of " << n;
}

void ExpectBalance(const ImpairmentModel& m) {
  const ImpairmentCounters& c = m.counters();
  EXPECT_EQ(c.offered + c.duplicated, c.delivered + c.dropped() + m.in_flight());
}

// Offers one datagram per period (its byte 0..3 = its index) and delivers at each period; records per datagram
// whether it arrived and its delay.
struct Stream {
  explicit Stream(const ImpairmentConfig& config, std::uint64_t seed = 5) : model(config, seed, "test") {}
  void Run(int n) {
    arrived.assign(static_cast<std::size_t>(n), false);
    delay_ns.assign(static_cast<std::size_t>(n), -1);
    std::array<std::uint8_t, 64> bytes{};
    for (int i = 0; i <= n + 2000; ++i) {
      const std::int64_t now = static_cast<std::int64_t>(i) * kPeriodNs;
      if (i < n) {
        for (int b = 0; b < 4; ++b) bytes[static_cast<std::size_t>(b)] = static_cast<std::uint8_t>(i >> (8 * b));
        (void)model.Offer(bytes, now);
      }
      model.BeginDelivery(now);
      ImpairmentModel::Delivery d;
      while (model.NextDelivery(d)) {
        int index = 0;
        for (int b = 0; b < 4; ++b) index |= d.bytes[static_cast<std::size_t>(b)] << (8 * b);
        ASSERT_LT(index, n);
        const auto k = static_cast<std::size_t>(index);
        if (!arrived[k]) delay_ns[k] = d.due_ns - static_cast<std::int64_t>(index) * kPeriodNs;
        arrived[k] = true;
        order.push_back(index);
      }
    }
  }
  ImpairmentModel model;
  std::vector<bool> arrived;
  std::vector<std::int64_t> delay_ns;
  std::vector<int> order;
};

TEST(ImpairmentModel, GilbertElliottBurstsHaveTheConfiguredRateAndLength) {
  ImpairmentConfig c;
  c.burst = {.enter_probability = 0.01, .exit_probability = 0.2, .loss_probability = 1.0};
  Stream s(c);
  constexpr int kN = 50000;
  s.Run(kN);
  // Stationary fraction in the bad state p / (p + r) = 1/21; mean burst 1 / r = 5 datagrams.
  const double expected = 0.01 / 0.21;
  const double rate = static_cast<double>(s.model.counters().dropped_burst) / kN;
  EXPECT_NEAR(rate, expected, 0.25 * expected);  // bursts are correlated: a wider band than the binomial one
  int bursts = 0;
  int lost = 0;
  for (int i = 0; i < kN; ++i) {
    if (!s.arrived[static_cast<std::size_t>(i)]) {
      ++lost;
      if (i == 0 || s.arrived[static_cast<std::size_t>(i - 1)]) ++bursts;
    }
  }
  EXPECT_EQ(static_cast<std::uint64_t>(lost), s.model.counters().dropped_burst);
  EXPECT_NEAR(static_cast<double>(lost) / bursts, 5.0, 0.75);
  EXPECT_EQ(s.model.counters().dropped_loss, 0u);
  ExpectBalance(s.model);
}

TEST(ImpairmentModel, JitterAddsUpToItsRangeAndNeverReorders) {
  ImpairmentConfig c;
  c.delay_s = 0.005;
  c.jitter_s = 0.004;
  Stream s(c);
  s.Run(10000);
  double sum = 0;
  for (std::int64_t d : s.delay_ns) {
    ASSERT_GE(d, 5'000'000);
    ASSERT_LE(d, 9'000'000);
    sum += static_cast<double>(d);
  }
  // Mean above delay + jitter/2 (the queue holds a datagram behind a slower predecessor), below delay + jitter.
  EXPECT_GT(sum / 10000, 7.0e6);
  EXPECT_LT(sum / 10000, 9.0e6);
  for (std::size_t i = 1; i < s.order.size(); ++i) ASSERT_LT(s.order[i - 1], s.order[i]);
  EXPECT_EQ(s.model.counters().delayed, 10000u);
  EXPECT_EQ(s.model.counters().reordered, 0u);
}

TEST(ImpairmentModel, OutagesDropExactlyTheScheduledWindows) {
  ImpairmentConfig c;
  c.outages = {{.start_s = 0.1, .duration_s = 0.05}, {.start_s = 0.5, .duration_s = 0.2}};
  Stream s(c);
  s.Run(1000);
  for (int i = 0; i < 1000; ++i) {
    const bool out = (i >= 100 && i < 150) || (i >= 500 && i < 700);
    ASSERT_EQ(s.arrived[static_cast<std::size_t>(i)], !out) << i;
  }
  EXPECT_EQ(s.model.counters().dropped_outage, 250u);
  ExpectBalance(s.model);
}

// link.emulate.delay_steps: 1 ms, then 60 ms from 0.3 s, then 1 ms from 0.6 s. Each datagram gets the delay of
// the step it was offered in, except after the step down: the queue holds, so those wait for the 60 ms ones ahead.
TEST(ImpairmentModel, DelayStepsChangeTheDelayInOrder) {
  ImpairmentConfig c;
  c.delay_s = 0.001;
  c.capacity = 256;
  c.delay_steps = {{.at_s = 0.3, .delay_s = 0.060}, {.at_s = 0.6, .delay_s = 0.001}};
  Stream s(c);
  s.Run(1000);
  for (int i = 0; i < 1000; ++i) {
    const auto k = static_cast<std::size_t>(i);
    ASSERT_TRUE(s.arrived[k]) << i;
    if (i < 300) {
      ASSERT_EQ(s.delay_ns[k], 1'000'000) << i;
    } else if (i < 600) {
      ASSERT_EQ(s.delay_ns[k], 60'000'000) << i;
    } else {
      // Never before the last 60 ms one (offered at 599 ms, due at 659 ms); from 659 ms on, 1 ms again.
      ASSERT_EQ(s.delay_ns[k], std::max<std::int64_t>(1'000'000, 659'000'000 - i * kPeriodNs)) << i;
    }
  }
  for (std::size_t i = 1; i < s.order.size(); ++i) ASSERT_LT(s.order[i - 1], s.order[i]);
  EXPECT_THAT(s.model.Describe(), ::testing::HasSubstr("then 60.000 ms from 0.300 s, then 1.000 ms from 0.600 s"));
  ImpairmentConfig bad = c;
  bad.delay_steps = {{.at_s = 0.6, .delay_s = 0.06}, {.at_s = 0.3, .delay_s = 0.001}};
  EXPECT_THROW(ImpairmentModel(bad, 1, "test"), Error);
}

TEST(ImpairmentModel, TheOutageScheduleStartsAtTheOrigin) {
  ImpairmentConfig c;
  c.outages = {{.start_s = 1.0, .duration_s = 0.5}};
  ImpairmentModel m(c, 1, "test");
  m.Start(10'000'000'000);
  const std::array<std::uint8_t, 8> bytes{};
  EXPECT_EQ(m.Offer(bytes, 10'900'000'000), ImpairmentModel::Verdict::kQueued);
  EXPECT_EQ(m.Offer(bytes, 11'000'000'000), ImpairmentModel::Verdict::kDropped);
  EXPECT_EQ(m.Offer(bytes, 11'500'000'000), ImpairmentModel::Verdict::kQueued);
}

TEST(ImpairmentModel, WhatTheLineCannotHoldIsCountedNotLost) {
  ImpairmentConfig c;
  c.capacity = 2;
  c.delay_s = 1.0;
  c.corrupt_probability = 1.0;  // would flip bits of an empty datagram if it were queued
  ImpairmentModel m(c, 1, "test");
  const std::array<std::uint8_t, 8> bytes{};
  std::array<std::uint8_t, ImpairmentModel::kMaxDatagramBytes + 1> huge{};
  EXPECT_EQ(m.Offer(std::span<const std::uint8_t>(), 0), ImpairmentModel::Verdict::kOverflow);
  EXPECT_EQ(m.Offer(huge, 0), ImpairmentModel::Verdict::kOverflow);
  EXPECT_EQ(m.Offer(bytes, 0), ImpairmentModel::Verdict::kQueued);
  EXPECT_EQ(m.Offer(bytes, 0), ImpairmentModel::Verdict::kQueued);
  EXPECT_EQ(m.Offer(bytes, 0), ImpairmentModel::Verdict::kOverflow);  // both slots in flight
  EXPECT_EQ(m.counters().dropped_overflow, 3u);
  EXPECT_EQ(m.counters().offered, 5u);
  ExpectBalance(m);
}

TEST(ImpairmentModel, BandwidthCapLimitsTheDeliveredRateAndDropsWhatTheQueueCannotHold) {
  ImpairmentConfig c;
  // 64-byte datagrams every 1 ms = 512 kbit/s offered into a 256 kbit/s line: about half gets through.
  c.bandwidth_bit_per_s = 256000;
  c.queue_limit_s = 0.010;
  Stream s(c);
  s.Run(10000);
  const ImpairmentCounters& k = s.model.counters();
  EXPECT_NEAR(static_cast<double>(k.delivered) / 10000, 0.5, 0.01);
  EXPECT_EQ(k.dropped_bandwidth, 10000 - k.delivered);
  for (std::int64_t d : s.delay_ns) {
    if (d >= 0) {
      ASSERT_LE(d, 10'000'000 + 2'000'000);  // the queue limit plus one transmission time
    }
  }
  ExpectBalance(s.model);
}

TEST(ImpairmentModel, SameSeedSameImpairmentsAndSettingsDoNotShiftEachOther) {
  ImpairmentConfig c;
  c.delay_s = 0.003;
  c.loss_probability = 0.1;
  Stream a(c, 77);
  Stream b(c, 77);
  a.Run(5000);
  b.Run(5000);
  EXPECT_EQ(a.arrived, b.arrived);
  EXPECT_EQ(a.delay_ns, b.delay_ns);
  // Jitter, duplication and reordering on: the same datagrams are lost (each impairment has its own stream).
  c.jitter_s = 0.002;
  c.duplicate_probability = 0.2;
  c.reorder_probability = 0.2;
  Stream d(c, 77);
  d.Run(5000);
  EXPECT_EQ(a.arrived, d.arrived);
  Stream e(c, 78);
  e.Run(5000);
  EXPECT_NE(d.arrived, e.arrived);
}

TEST(ImpairmentModel, BadSettingsAreSetUpErrorsNamingTheSetting) {
  const auto error_of = [](const ImpairmentConfig& c) -> std::string {
    try {
      ImpairmentModel m(c, 1, "link.emulate");
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  ImpairmentConfig c;
  c.jitter_s = -1;
  EXPECT_THAT(error_of(c), ::testing::HasSubstr("link.emulate: jitter_s must be finite and >= 0"));
  c = {};
  c.burst.enter_probability = 0.1;
  c.burst.exit_probability = 0.0;
  EXPECT_THAT(error_of(c), ::testing::HasSubstr("a burst would never end"));
  c = {};
  c.outages = {{.start_s = 1, .duration_s = 0}};
  EXPECT_THAT(error_of(c), ::testing::HasSubstr("outage duration_s"));
  c = {};
  c.bandwidth_bit_per_s = std::nan("");
  EXPECT_THAT(error_of(c), ::testing::HasSubstr("bandwidth_bit_per_s"));
}

// ---- ImpairedLink around a link (an ideal EmulatedLink, so the test controls the clock) ----------------------

std::int64_t g_now_ns = 0;
std::int64_t FakeClock() noexcept { return g_now_ns; }

struct Wrapped {
  explicit Wrapped(const ImpairmentConfig& c, std::uint64_t seed = 3) {
    g_now_ns = 0;
    EmulatedLinkPair pair = MakeEmulatedLinkPair(EmulatedLinkConfig{});
    medium = pair.medium;
    master = std::move(pair.master);
    auto slave = std::move(pair.slave);
    inner = slave.get();
    link = std::make_unique<ImpairedLink>(std::move(slave), c, seed, SenderRole::kMaster, &FakeClock);
  }
  // The master sends one sample per period; the slave polls through the wrapper.
  void Run(int n) {
    proto::SampleMessage got;
    for (int i = 0; i < n + 1000; ++i) {
      if (i < n) (void)master->Send(MakeSample(SenderRole::kMaster, static_cast<std::uint32_t>(i + 1), 1));
      if (link->Poll(got)) {
        ++polls_with_news;
        last = got;
      }
      g_now_ns += kPeriodNs;
      medium->Advance(1e-3);
    }
  }
  std::shared_ptr<EmulatedMedium> medium;
  std::unique_ptr<EmulatedLink> master;
  EmulatedLink* inner = nullptr;
  std::unique_ptr<ImpairedLink> link;
  int polls_with_news = 0;
  proto::SampleMessage last{};
};

TEST(ImpairedLink, DelaysWhatTheWrappedLinkReceivesOnTheClock) {
  ImpairmentConfig c;
  c.delay_s = 0.0035;
  Wrapped w(c);
  (void)w.master->Send(MakeSample(SenderRole::kMaster, 1, 1));
  proto::SampleMessage got;
  for (int ms = 0; ms <= 3; ++ms) {
    EXPECT_FALSE(w.link->Poll(got)) << ms;
    g_now_ns += kPeriodNs;
  }
  ASSERT_TRUE(w.link->Poll(got));  // at 4 ms ≥ 3.5 ms
  EXPECT_EQ(got.sequence, 1u);
  EXPECT_EQ(w.link->newest_receive_time_ns(), 3'500'000);
  EXPECT_EQ(w.inner->counters().accepted, 1u);  // the wrapped link took it at once
  EXPECT_EQ(w.link->impairments().delayed, 1u);
}

TEST(ImpairedLink, LossIsSeenByTheLoopAsLostAndTheWrappedCountersStayTrue) {
  ImpairmentConfig c;
  c.delay_s = 0.002;
  c.loss_probability = 0.2;
  Wrapped w(c);
  constexpr int kN = 20000;
  w.Run(kN);
  const ImpairmentCounters& e = w.link->impairments();
  ExpectRate(e.dropped_loss, kN, 0.2);
  const LinkCounters& seen = w.link->counters();
  const LinkCounters& inner = w.inner->counters();
  EXPECT_EQ(inner.accepted, static_cast<std::uint64_t>(kN));  // the wrapped link lost nothing and says so
  EXPECT_EQ(inner.lost, 0u);
  test::ExpectCountersBalance(inner);
  test::ExpectCountersBalance(seen);
  EXPECT_EQ(seen.accepted, kN - e.dropped_loss);
  EXPECT_LE(seen.lost, e.dropped_loss);  // drops after the last arrival are no gap (yet)
  EXPECT_GE(seen.lost + 5, e.dropped_loss);
  EXPECT_EQ(seen.sent, 0u);
}

TEST(ImpairedLink, CorruptionIsRejectedByTheDecoderAndDuplicatesAndReordersAreCounted) {
  ImpairmentConfig c;
  c.delay_s = 0.003;
  c.corrupt_probability = 0.02;
  c.duplicate_probability = 0.03;
  c.reorder_probability = 0.04;
  Wrapped w(c);
  w.Run(20000);
  const ImpairmentCounters& e = w.link->impairments();
  const LinkCounters& seen = w.link->counters();
  EXPECT_EQ(w.inner->counters().rejected, 0u);
  EXPECT_EQ(seen.rejected, e.corrupted);  // every flipped bit caught (CRC-32C, or the checks before it)
  EXPECT_GT(test::Rejected(seen, proto::DecodeStatus::kBadCrc), seen.rejected / 2);
  EXPECT_GT(seen.duplicates, 0u);
  EXPECT_GT(seen.reordered, 0u);
  ExpectRate(e.reordered, 20000, 0.04);
  test::ExpectCountersBalance(seen);
}

TEST(ImpairedLink, TheSameSeedGivesTheSameRun) {
  ImpairmentConfig c;
  c.delay_s = 0.004;
  c.jitter_s = 0.003;
  c.loss_probability = 0.05;
  c.burst = {.enter_probability = 0.005, .exit_probability = 0.3, .loss_probability = 1.0};
  c.corrupt_probability = 0.01;
  Wrapped a(c, 11);
  a.Run(3000);
  const LinkCounters first = a.link->counters();
  const ImpairmentCounters first_e = a.link->impairments();
  Wrapped b(c, 11);
  b.Run(3000);
  EXPECT_EQ(b.link->counters().accepted, first.accepted);
  EXPECT_EQ(b.link->counters().lost, first.lost);
  EXPECT_EQ(b.link->counters().rejected, first.rejected);
  EXPECT_EQ(b.link->impairments().dropped_burst, first_e.dropped_burst);
  Wrapped d(c, 12);
  d.Run(3000);
  EXPECT_NE(d.link->impairments().dropped_loss * 1000 + d.link->impairments().dropped_burst,
            first_e.dropped_loss * 1000 + first_e.dropped_burst);
}

TEST(ImpairedLink, PollAndSendDoNotAllocate) {
  ImpairmentConfig c;
  c.capacity = 256;
  c.delay_s = 0.02;
  c.jitter_s = 0.01;
  c.loss_probability = 0.1;
  c.duplicate_probability = 0.1;
  c.reorder_probability = 0.1;
  c.corrupt_probability = 0.1;
  c.bandwidth_bit_per_s = 1e6;
  c.burst = {.enter_probability = 0.01, .exit_probability = 0.2, .loss_probability = 1.0};
  c.outages = {{.start_s = 0.5, .duration_s = 0.1}};
  Wrapped w(c);
  std::uint64_t allocations = 0;
  {
    teleop::test::AllocationCounter counter;
    w.Run(2000);
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  // Everything happened: jitter bunches samples (superseded), the rest is dropped, rejected or stale.
  EXPECT_GT(w.link->counters().accepted, 300u);
  EXPECT_GT(w.link->counters().superseded, 100u);
  const ImpairmentCounters& e = w.link->impairments();
  EXPECT_GT(e.dropped_loss * e.dropped_burst * e.dropped_outage * e.duplicated * e.reordered * e.corrupted, 0u);
  EXPECT_EQ(w.link->impairments().dropped_overflow, 0u);
}

TEST(ImpairedLink, SendsGoStraightToTheWrappedLink) {
  ImpairmentConfig c;
  c.delay_s = 1.0;
  c.loss_probability = 1.0;
  Wrapped w(c);
  ASSERT_TRUE(w.link->Send(MakeSample(SenderRole::kSlave, 1, 1)));
  proto::SampleMessage got;
  ASSERT_TRUE(w.master->Poll(got));  // not delayed, not lost: emulation is on the receive side only
  EXPECT_EQ(w.link->counters().sent, 1u);
  EXPECT_THAT(w.link->Describe(), ::testing::HasSubstr("emulate (receive side: delay 1000.000 ms, loss 1.000"));
  EXPECT_NE(EmulationCountersOf(*w.link), nullptr);
  EXPECT_EQ(EmulationCountersOf(*w.master), nullptr);
}

}  // namespace
}  // namespace teleop::transport
