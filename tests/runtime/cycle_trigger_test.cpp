// TriggerSchedule (phase-locked cycles) and DataAgeTracker on a fake clock: the schedule's deadlines, the timeout
// fallback, the flood guard; and, in a simulated pair (a master on its own clock, a link latency, a slave either
// free-running or triggered), the age of the master's sample when the slave's law uses it.

#include "teleop/runtime/cycle_trigger.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "teleop/runtime/data_age.hpp"

namespace teleop::runtime {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;  // 1 kHz
constexpr std::int64_t kMargin = 250'000;

TriggerSchedule::Config Config() {
  TriggerSchedule::Config c;
  c.period_ns = kPeriod;
  c.timeout_margin_ns = kMargin;
  c.min_spacing_ns = kPeriod / 2;
  return c;
}

TEST(TriggerSchedule, WaitsUntilOnePeriodPlusTheMarginThenExpectsOnePeriodAfterEachTrigger) {
  TriggerSchedule s(Config());
  s.Start(10'000'000);
  EXPECT_EQ(s.earliest_start_ns(), 10'000'000) << "the first cycle may start at once";
  EXPECT_EQ(s.deadline_ns(), 10'000'000 + kPeriod + kMargin);
  // The master's sample arrives 30 µs early: triggered, 30 µs off the schedule; the next is expected a period on.
  EXPECT_EQ(s.CycleStarted(10'970'000, true), 30'000);
  EXPECT_EQ(s.expected_ns(), 11'970'000);
  EXPECT_EQ(s.deadline_ns(), 11'970'000 + kMargin);
  EXPECT_EQ(s.earliest_start_ns(), 10'970'000 + kPeriod / 2);
  EXPECT_EQ(s.triggered(), 1u);
  EXPECT_EQ(s.timeouts(), 0u);
}

TEST(TriggerSchedule, ATimeoutRunsTheCycleAndKeepsTheNominalCadence) {
  TriggerSchedule s(Config());
  s.Start(0);
  ASSERT_EQ(s.CycleStarted(kPeriod, true), 0);
  // No sample: the cycle runs at the deadline (counted), the next is still expected one period after the last.
  const std::int64_t deadline = s.deadline_ns();
  EXPECT_EQ(s.CycleStarted(deadline, false), 0);
  EXPECT_EQ(s.timeouts(), 1u);
  EXPECT_EQ(s.expected_ns(), 3 * kPeriod);
  // A silent peer: one cycle per period, offset by the margin.
  for (int k = 0; k < 5; ++k) {
    const std::int64_t d = s.deadline_ns();
    EXPECT_EQ(d, (3 + k) * kPeriod + kMargin);
    (void)s.CycleStarted(d, false);
  }
  EXPECT_EQ(s.timeouts(), 6u);
  // The peer comes back: triggered again.
  (void)s.CycleStarted(8 * kPeriod + 10'000, true);
  EXPECT_EQ(s.triggered(), 2u);
  EXPECT_EQ(s.expected_ns(), 9 * kPeriod + 10'000);
}

TEST(TriggerSchedule, LateWakeUpsOnTimeoutsDoNotSlowASilentPeersCadence) {
  TriggerSchedule s(Config());
  s.Start(0);
  // No peer; every timed-out wait returns 80 µs past its deadline (a VM's timer latency). The deadlines stay on the
  // grid one period apart: 100 cycles take 100 periods, not 100 × (period + 80 µs).
  for (int k = 0; k < 100; ++k) {
    const std::int64_t d = s.deadline_ns();
    EXPECT_EQ(d, (1 + k) * kPeriod + kMargin) << "cycle " << k;
    EXPECT_EQ(s.CycleStarted(d + 80'000, false), 80'000);
  }
  EXPECT_EQ(s.timeouts(), 100u);
}

TEST(TriggerSchedule, AfterAStallTheNextDeadlineIsNotInThePast) {
  TriggerSchedule s(Config());
  s.Start(0);
  // The process was preempted for 20 periods: the wait returns far past its deadline.
  const std::int64_t late = 20 * kPeriod;
  EXPECT_EQ(s.CycleStarted(late, false), late - (kPeriod + kMargin)) << "how late the cycle started";
  EXPECT_GE(s.deadline_ns(), late + kPeriod) << "no burst of timeout cycles to catch up";
}

TEST(TriggerSchedule, AFloodCannotRunCyclesCloserThanTheMinimumSpacing) {
  TriggerSchedule s(Config());
  s.Start(0);
  std::int64_t now = 0;
  // A peer (or an attacker) whose datagrams make the socket readable all the time: each cycle may start only at
  // earliest_start_ns, so the rate is at most twice the nominal one.
  for (int k = 0; k < 100; ++k) {
    now = std::max(now, s.earliest_start_ns());
    (void)s.CycleStarted(now, true);
  }
  EXPECT_GE(now, 99 * (kPeriod / 2));
}

TEST(DataAgeTracker, RecordsReceiveAndSenderAgeAndAgeInCycles) {
  DataAgeTracker t;
  t.OnCycle(1000, false);  // no sample yet: nothing recorded
  EXPECT_EQ(t.receive_age_ns().count(), 0u);
  EXPECT_EQ(t.ReceiveAgeNs(1000), -1);
  t.OnNewSample(/*receive_ns=*/100'000, /*sent_local_ns=*/90'000, /*triggered=*/true);
  t.OnCycle(120'000, true);  // used 20 µs after receive, 30 µs after the send
  EXPECT_EQ(t.receive_age_ns().max_ns(), 20'000);
  EXPECT_EQ(t.sender_age_ns().max_ns(), 30'000);
  t.OnCycle(1'120'000, true);          // reused one cycle later (no newer sample)
  t.OnNewSample(1'900'000, 0, false);  // sender time unknown; not triggered
  t.OnCycle(2'120'000, true);
  t.OnCycle(3'120'000, false);  // peer unusable: not recorded, but the sample ages
  t.OnCycle(4'120'000, true);
  t.OnCycle(5'120'000, true);
  const auto& c = t.age_cycles();
  EXPECT_EQ(c[0], 1u);
  EXPECT_EQ(c[1], 2u);
  EXPECT_EQ(c[2], 0u);
  EXPECT_EQ(c[3], 2u) << "3 and 4 cycles old land in the last bucket";
  EXPECT_EQ(t.receive_age_ns().count(), 5u);
  EXPECT_EQ(t.sender_age_ns().count(), 2u) << "no sender age without the sender's time";
  EXPECT_EQ(t.MedianAgeCycles(), 1);
}

// A master on its own clock (period T, ±20 µs jitter) sends at each cycle start; the datagram reaches the slave
// `latency` later. The slave either free-runs at its own phase or is triggered by the arrival (after a wake-up
// latency). Returns the slave's tracker.
DataAgeTracker SimulatePair(bool triggered, std::int64_t slave_phase_ns, std::int64_t latency_ns, std::int64_t wake_ns,
                            int cycles, const std::vector<int>& lost = {}) {
  DataAgeTracker age;
  TriggerSchedule schedule(Config());
  std::vector<std::int64_t> arrivals;
  for (int k = 0; k < cycles + 2; ++k) {
    const std::int64_t jitter = (k * 7919) % 40'000 - 20'000;  // ±20 µs, deterministic
    bool dropped = false;
    for (const int l : lost) dropped = dropped || l == k;
    if (!dropped) arrivals.push_back((k + 1) * kPeriod + jitter + latency_ns);  // the master starts at T
  }
  std::size_t next = 0;  // first arrival not yet polled
  auto poll = [&](std::int64_t now, bool cycle_triggered) {
    bool fresh = false;
    std::int64_t newest = 0;
    while (next < arrivals.size() && arrivals[next] <= now) {
      newest = arrivals[next++];
      fresh = true;
    }
    if (fresh) age.OnNewSample(newest, newest - latency_ns, cycle_triggered);
    age.OnCycle(now, next > 0);
  };
  if (!triggered) {
    for (int k = 1; k <= cycles; ++k) poll(k * kPeriod + slave_phase_ns, false);
    return age;
  }
  schedule.Start(0);
  std::int64_t now = 0;
  for (int k = 0; k < cycles; ++k) {
    now = std::max(now, schedule.earliest_start_ns());
    // Wait for the next arrival until the deadline (what PeriodicLoop does with Link::WaitReadable).
    const bool fired = next < arrivals.size() && arrivals[next] <= schedule.deadline_ns();
    now = fired ? std::max(now, arrivals[next]) + wake_ns : schedule.deadline_ns();
    (void)schedule.CycleStarted(now, fired);
    poll(now, fired);
  }
  return age;
}

TEST(PhaseLockedPair, TriggeredTheSlaveUsesTheMastersSampleOfTheSameCycle) {
  const DataAgeTracker age = SimulatePair(/*triggered=*/true, 0, /*latency_ns=*/15'000, /*wake_ns=*/10'000, 1000);
  EXPECT_EQ(age.MedianAgeCycles(), 0);
  EXPECT_EQ(age.age_cycles()[0], age.receive_age_ns().count()) << "every cycle was started by its sample";
  EXPECT_EQ(age.receive_age_ns().max_ns(), 10'000) << "the age is the wake-up latency";
  EXPECT_EQ(age.sender_age_ns().max_ns(), 25'000) << "plus the link latency since the master sent it";
}

TEST(PhaseLockedPair, FreeRunningTheSlaveUsesASampleOneCycleOld) {
  for (const std::int64_t phase : {100'000, 500'000, 900'000}) {
    const DataAgeTracker age = SimulatePair(/*triggered=*/false, phase, 15'000, 0, 1000);
    EXPECT_EQ(age.MedianAgeCycles(), 1) << "phase " << phase;
    EXPECT_EQ(age.age_cycles()[0], 0u);
    // The sample waited for the slave's cycle for (phase − latency) ± the master's jitter.
    EXPECT_NEAR(static_cast<double>(age.receive_age_ns().Percentile(0.5)), static_cast<double>(phase - 15'000),
                25'000.0)
        << "phase " << phase;
  }
}

TEST(PhaseLockedPair, ALostSampleIsATimeoutAndTheOldSampleIsReused) {
  const DataAgeTracker age = SimulatePair(true, 0, 15'000, 10'000, 100, /*lost=*/{40, 41});
  EXPECT_EQ(age.age_cycles()[1], 1u) << "the cycle after the first loss reuses the last sample";
  EXPECT_EQ(age.age_cycles()[2], 1u) << "and the next one again";
  EXPECT_EQ(age.MedianAgeCycles(), 0);
}

}  // namespace
}  // namespace teleop::runtime
