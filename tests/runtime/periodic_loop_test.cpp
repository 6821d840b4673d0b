#include "teleop/runtime/periodic_loop.hpp"

#include <gtest/gtest.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::runtime {
namespace {

// Timing quality is not asserted (shared, noisy machines): only counts, indices and that the statistics are
// filled consistently.

TEST(PeriodicLoop, RunsUntilStoppedFromTheBodyAndFillsStats) {
  constexpr std::uint64_t kCycles = 100;
  PeriodicLoop loop({.rate_hz = 1000.0});
  EXPECT_DOUBLE_EQ(loop.period_s(), 1e-3);
  std::vector<std::uint64_t> seen;
  seen.reserve(kCycles);
  double seen_period_s = 0.0;
  loop.Run([&](std::uint64_t cycle, double period_s) {
    seen.push_back(cycle);
    seen_period_s = period_s;
    if (cycle + 1 == kCycles) loop.Stop();
  });
  const CycleStats& stats = loop.stats();
  ASSERT_EQ(seen.size(), kCycles);
  for (std::uint64_t i = 0; i < kCycles; ++i) EXPECT_EQ(seen[i], i) << "consecutive cycle indices";
  EXPECT_DOUBLE_EQ(seen_period_s, 1e-3);
  EXPECT_EQ(stats.cycles, kCycles);
  EXPECT_EQ(stats.jitter_ns.count(), kCycles);
  EXPECT_EQ(stats.compute_ns.count(), kCycles);
  EXPECT_EQ(stats.period_ns.count(), kCycles - 1) << "wake-to-wake needs two wakes";
  EXPECT_GT(stats.period_ns.mean_ns(), 0.0);
  EXPECT_GE(stats.jitter_ns.min_ns(), 0) << "an absolute sleep never wakes early";
  EXPECT_LE(stats.overruns, stats.cycles + stats.skipped_slots);
  EXPECT_TRUE(loop.stopping());
}

// Triggered (phase-locked) mode with a fake trigger: what starts each cycle is counted, the body sees it, and a
// trigger that never fires still runs the loop (timeouts, the free-running fallback).
TEST(PeriodicLoopTriggered, EveryCycleStartedByTheTriggerIsCountedAndVisibleToTheBody) {
  PeriodicLoop loop({.rate_hz = 1000.0, .sync = CycleSync::kTriggered});
  std::vector<std::int64_t> deadlines;
  deadlines.reserve(64);
  loop.SetTrigger([&](std::int64_t deadline_ns) {
    deadlines.push_back(deadline_ns);
    return true;  // the peer's sample is always there
  });
  ASSERT_TRUE(loop.triggered_mode());
  std::uint64_t seen_triggered = 0;
  loop.Run([&](std::uint64_t cycle, double) {
    if (loop.cycle_triggered()) ++seen_triggered;
    if (cycle + 1 == 20) loop.Stop();
  });
  EXPECT_EQ(loop.stats().cycles, 20u);
  EXPECT_EQ(loop.stats().triggered_cycles, 20u);
  EXPECT_EQ(loop.stats().trigger_timeouts, 0u);
  EXPECT_EQ(seen_triggered, 20u);
  ASSERT_EQ(deadlines.size(), 20u);
  for (std::size_t i = 1; i < deadlines.size(); ++i) {
    EXPECT_GT(deadlines[i], deadlines[i - 1]) << "each deadline is one period after the last trigger";
  }
}

TEST(PeriodicLoopTriggered, ASilentPeerIsATimeoutEveryCycleAndTheLoopKeepsRunning) {
  PeriodicLoop loop({.rate_hz = 2000.0, .sync = CycleSync::kTriggered, .trigger_timeout_margin_ns = 100'000});
  loop.SetTrigger([](std::int64_t deadline_ns) {
    timespec until{static_cast<time_t>(deadline_ns / 1'000'000'000), static_cast<long>(deadline_ns % 1'000'000'000)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr);
    return false;
  });
  bool any_triggered = false;
  loop.Run([&](std::uint64_t cycle, double) {
    any_triggered = any_triggered || loop.cycle_triggered();
    if (cycle + 1 == 10) loop.Stop();
  });
  EXPECT_EQ(loop.stats().cycles, 10u);
  EXPECT_EQ(loop.stats().trigger_timeouts, 10u);
  EXPECT_EQ(loop.stats().triggered_cycles, 0u);
  EXPECT_FALSE(any_triggered);
}

TEST(PeriodicLoopTriggered, SpinPollsTheTriggerWithoutSleepingBeforeTheExpectedArrival) {
  PeriodicLoop loop({.rate_hz = 1000.0, .sync = CycleSync::kTriggered, .trigger_spin_ns = 200'000});
  std::int64_t last_deadline = 0;
  int polls = 0;
  int sleeps = 0;
  loop.SetTrigger([&](std::int64_t deadline_ns) {
    if (deadline_ns == 0) {  // a poll without sleeping: the peer's sample is there (the first poll, whatever the
      ++polls;               // time: a deadline missed on a loaded machine cannot turn it into a timeout)
      return true;
    }
    ++sleeps;
    last_deadline = deadline_ns;
    timespec until{static_cast<time_t>(deadline_ns / 1'000'000'000), static_cast<long>(deadline_ns % 1'000'000'000)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr);
    return false;
  });
  loop.Run([&](std::uint64_t cycle, double) {
    if (cycle + 1 == 5) loop.Stop();
  });
  EXPECT_EQ(loop.stats().triggered_cycles, 5u) << "each cycle started by a spin poll that saw the sample";
  EXPECT_EQ(sleeps, 5) << "one sleep per cycle, up to the spin window";
  EXPECT_EQ(polls, 5);
  EXPECT_GT(last_deadline, 0);
}

TEST(PeriodicLoopTriggered, WithoutATriggerOrInFreeModeTheLoopRunsOnItsClock) {
  PeriodicLoop free_loop({.rate_hz = 1000.0, .duration_s = 0.005});
  bool called = false;
  free_loop.SetTrigger([&](std::int64_t) { return called = true; });
  EXPECT_FALSE(free_loop.triggered_mode()) << "sync free ignores a trigger";
  free_loop.Run([](std::uint64_t, double) {});
  EXPECT_FALSE(called);
  EXPECT_EQ(free_loop.stats().triggered_cycles + free_loop.stats().trigger_timeouts, 0u);
  PeriodicLoop no_trigger({.rate_hz = 1000.0, .duration_s = 0.005, .sync = CycleSync::kTriggered});
  EXPECT_FALSE(no_trigger.triggered_mode()) << "no trigger set: free-running";
}

TEST(PeriodicLoop, DurationStopsAfterItsSlots) {
  // 50 ms at 1 kHz = slots 0..49. Without skipped slots exactly 50 cycles run; with skips, the skipped slots make
  // up the difference.
  PeriodicLoop loop({.rate_hz = 1000.0, .duration_s = 0.05});
  std::uint64_t calls = 0;
  loop.Run([&](std::uint64_t, double) { ++calls; });
  const CycleStats& stats = loop.stats();
  EXPECT_EQ(calls, stats.cycles);
  EXPECT_LE(stats.cycles, 50u);
  EXPECT_GE(stats.cycles + stats.skipped_slots, 50u);
  if (stats.skipped_slots == 0) {
    EXPECT_EQ(stats.cycles, 50u);
  }
}

TEST(PeriodicLoop, LongOverrunSkipsMissedSlotsAndCountsThem) {
  // Cycle 5 takes 3.5 periods: its own deadline is missed (1 overrun) and the slots that passed entirely while it
  // ran (at least 2) are skipped and counted instead of being run back to back.
  PeriodicLoop loop({.rate_hz = 1000.0});
  loop.Run([&](std::uint64_t cycle, double) {
    if (cycle == 5) {
      const timespec busy{0, 3'500'000};
      nanosleep(&busy, nullptr);
    }
    if (cycle == 20) loop.Stop();
  });
  const CycleStats& stats = loop.stats();
  EXPECT_EQ(stats.cycles, 21u);
  EXPECT_GE(stats.skipped_slots, 2u);
  EXPECT_GE(stats.overruns, stats.skipped_slots + 1);
  EXPECT_GE(stats.compute_ns.max_ns(), 3'500'000);
}

TEST(PeriodicLoop, StoppedBeforeRunDoesNotRun) {
  PeriodicLoop loop({.rate_hz = 1000.0});
  loop.Stop();
  int calls = 0;
  loop.Run([&](std::uint64_t, double) { ++calls; });
  EXPECT_EQ(calls, 0);
  EXPECT_EQ(loop.stats().cycles, 0u);
}

TEST(PeriodicLoop, TheLoopItselfDoesNotAllocate) {
  PeriodicLoop loop({.rate_hz = 2000.0});
  const PeriodicLoop::Body body = [&loop](std::uint64_t cycle, double) {
    if (cycle == 30) loop.Stop();
  };
  test::AllocationCounter counter;
  loop.Run(body);
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_EQ(loop.stats().cycles, 31u);
}

TEST(PeriodicLoop, RejectsBadConfig) {
  EXPECT_THROW(PeriodicLoop({.rate_hz = 0.0}), Error);
  EXPECT_THROW(PeriodicLoop({.rate_hz = -1000.0}), Error);
  EXPECT_THROW(PeriodicLoop({.rate_hz = 1.0 / 0.0}), Error);
  EXPECT_THROW(PeriodicLoop({.rate_hz = 1000.0, .fifo_priority = 100}), Error);
  EXPECT_THROW(PeriodicLoop({.rate_hz = 1000.0, .cpu = -2}), Error);
  EXPECT_THROW(PeriodicLoop({.rate_hz = 1000.0, .duration_s = -1.0}), Error);
}

TEST(PeriodicLoop, NonexistentCpuFailsAtSetUpWithAHint) {
  PeriodicLoop loop({.rate_hz = 1000.0, .cpu = 4096});
  int calls = 0;
  try {
    loop.Run([&](std::uint64_t, double) { ++calls; });
    FAIL() << "expected teleop::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cpu 4096"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("realtime.cpu"), std::string::npos) << e.what();
  }
  EXPECT_EQ(calls, 0);
}

// Whether this process has `path` open (through /proc/self/fd).
bool HoldsOpen(const std::filesystem::path& path) {
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/fd", ec)) {
    std::error_code link_ec;
    const std::filesystem::path target = std::filesystem::read_symlink(entry.path(), link_ec);
    if (!link_ec && target == path) return true;
  }
  return false;
}

/// A path under a directory that does not exist.
std::filesystem::path TempPath(const std::string& name) {
  return std::filesystem::path(::testing::TempDir()) / (name + "-" + std::to_string(getpid()));
}

TEST(PeriodicLoopDmaLatency, HoldsTheRequestOpenWithTheValueForTheRunOnly) {
  // A regular file stands in for /dev/cpu_dma_latency: the loop writes the 32-bit value and keeps it open.
  const test::ScopedTempDir dir("dma-latency");
  const std::filesystem::path path = std::filesystem::canonical(dir.path()) / "cpu_dma_latency";
  { std::ofstream create(path); }
  PeriodicLoopConfig config;
  config.rate_hz = 1000.0;
  config.cpu_dma_latency_us = 7;
  config.cpu_dma_latency_path = path.string();
  PeriodicLoop loop(config);
  bool held_in_body = false;
  loop.Run([&](std::uint64_t cycle, double) {
    if (cycle == 2) {
      held_in_body = HoldsOpen(path);
      loop.Stop();
    }
  });
  EXPECT_TRUE(held_in_body) << "the request is open while the loop runs";
  EXPECT_FALSE(HoldsOpen(path)) << "and closed when Run returns";
  EXPECT_TRUE(loop.stats().cpu_dma_latency_held);
  EXPECT_EQ(loop.stats().setting_warnings, 0u);
  EXPECT_EQ(loop.stats().cpu_dma_latency_errno, 0);
  EXPECT_FALSE(loop.stats().realtime_settings_applied) << "no SCHED_FIFO, no mlockall";
  EXPECT_EQ(std::filesystem::file_size(path), sizeof(std::int32_t)) << "exactly one 32-bit value written";
  std::ifstream in(path, std::ios::binary);
  std::array<char, sizeof(std::int32_t)> bytes{};
  in.read(bytes.data(), bytes.size());
  std::int32_t value = 0;
  std::memcpy(&value, bytes.data(), sizeof value);
  EXPECT_TRUE(in.good());
  EXPECT_EQ(value, 7);
}

TEST(PeriodicLoopDmaLatency, AnUnopenablePathIsACountedWarningNotAnError) {
  PeriodicLoopConfig config;
  config.rate_hz = 1000.0;
  config.duration_s = 0.005;
  config.cpu_dma_latency_us = 0;
  config.cpu_dma_latency_path = (TempPath("teleop-no-such-dir") / "cpu_dma_latency").string();
  PeriodicLoop loop(config);
  std::uint64_t calls = 0;
  EXPECT_NO_THROW(loop.Run([&](std::uint64_t, double) { ++calls; }));
  EXPECT_GT(calls, 0u) << "the loop runs without the setting";
  EXPECT_FALSE(loop.stats().cpu_dma_latency_held);
  EXPECT_EQ(loop.stats().setting_warnings, 1u);
  EXPECT_EQ(loop.stats().cpu_dma_latency_errno, ENOENT);
  EXPECT_FALSE(loop.stats().realtime_settings_applied);
}

TEST(PeriodicLoopDmaLatency, NotAskedTouchesNothingAndInvalidValueIsRejected) {
  PeriodicLoopConfig config;
  config.rate_hz = 1000.0;
  config.duration_s = 0.003;
  config.cpu_dma_latency_path = (TempPath("teleop-untouched") / "x").string();  // would fail if opened
  PeriodicLoop loop(config);
  loop.Run([](std::uint64_t, double) {});
  EXPECT_EQ(loop.stats().setting_warnings, 0u);
  EXPECT_FALSE(loop.stats().cpu_dma_latency_held);
  config.cpu_dma_latency_us = -2;
  EXPECT_THROW(PeriodicLoop{config}, Error);
}

// The loop thread's timer slack (docs/performance.md, "The 1 kHz jitter"): the kernel's 50 µs default would land in
// every normal-scheduled wake-up; the loop sets 1 ns for the run, and 0 leaves what the thread inherited.
TEST(PeriodicLoopTimerSlack, TheLoopSetsItsThreadsSlackAndZeroLeavesTheInheritedOne) {
  const long inherited = prctl(PR_GET_TIMERSLACK, 0UL, 0UL, 0UL, 0UL);
  ASSERT_GT(inherited, 0);
  PeriodicLoopConfig config;
  config.rate_hz = 1000.0;
  config.duration_s = 0.002;
  long seen_in_body = -1;
  {
    PeriodicLoop loop(config);  // default: 1 ns
    loop.Run([&](std::uint64_t, double) { seen_in_body = prctl(PR_GET_TIMERSLACK, 0UL, 0UL, 0UL, 0UL); });
    EXPECT_EQ(loop.stats().timer_slack_ns, 1);
    EXPECT_EQ(seen_in_body, 1);
    EXPECT_EQ(loop.stats().setting_warnings, 0u);
  }
  ASSERT_EQ(prctl(PR_SET_TIMERSLACK, static_cast<unsigned long>(inherited), 0UL, 0UL, 0UL), 0);
  config.timer_slack_ns = 0;
  {
    PeriodicLoop loop(config);
    loop.Run([](std::uint64_t, double) {});
    EXPECT_EQ(loop.stats().timer_slack_ns, inherited);
  }
  config.timer_slack_ns = -1;
  EXPECT_THROW(PeriodicLoop{config}, Error);
}

}  // namespace
}  // namespace teleop::runtime
