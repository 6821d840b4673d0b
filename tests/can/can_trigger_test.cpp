// The SYNC-like trigger of a triggered slave over CAN (docs/can.md, "Phase-locked cycles over CAN"), on the
// in-process emulated bus with a clock the test owns: CanLink::WaitReadable fires when the master's whole sample of
// a cycle has arrived (its last frame), never on a first frame, a partial or repeated cycle or foreign frames; a
// missing frame is a timeout at the deadline, after which the cycle runs; a flood of valid cycles cannot start the
// slave's cycles closer than the trigger schedule's minimum spacing. The loop is PeriodicLoop::RunTriggered's
// arithmetic (runtime::TriggerSchedule) stepped on the bus clock, so every time here is simulated, none measured.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>

#include "can_test_helpers.hpp"
#include "teleop/proto/can/bus_load.hpp"
#include "teleop/runtime/cycle_trigger.hpp"
#include "teleop/transport/can_emulated_bus.hpp"
#include "teleop/transport/can_link.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::transport {
namespace {

using proto::SenderRole;
using proto::can::CanFrame;

constexpr std::int64_t kPeriod_ns = 1'000'000;  // 1 kHz

proto::can::CanWireFormat Format(int dof) {
  proto::can::CanWireFormat f{};
  f.dof = dof;
  return f;
}

/// Time one classic 11-bit frame of `bytes` data bytes occupies the default 1 Mbit/s bus (ns).
std::int64_t FrameNs(int bytes) {
  return std::llround(
      proto::can::FrameTime_s(false, false, false, static_cast<std::size_t>(bytes), proto::can::CanBitrates{}) * 1e9);
}

/// A master and a triggered slave on one emulated bus. Sleeping in the slave's wait advances the test's clock; a
/// master schedule (`master_every_ns` > 0) sends a cycle whenever the clock passes its next send time, so the
/// master runs "during" the slave's wait as it would in its own process.
struct Rig {
  test::ManualClock clock;
  EmulatedCanBus bus;
  int master_node, slave_node, rogue_node;
  CanLink master, slave;
  int dof;
  std::int64_t master_every_ns = 0;
  std::int64_t next_master_send_ns = 0;
  std::uint32_t master_sequence = 0;
  /// Decides, per master cycle, how many of its frames go on the bus (all by default).
  std::function<int(std::uint32_t sequence, int frames)> frames_sent = [](std::uint32_t, int frames) { return frames; };

  explicit Rig(int dof_count)
      : bus(EmulatedCanBusConfig{}, [this] { return clock.now_ns; }),
        master_node(bus.AddNode()),
        slave_node(bus.AddNode()),
        rogue_node(bus.AddNode()),
        master(Format(dof_count), SenderRole::kMaster, bus.MakePort(master_node)),
        slave(Format(dof_count), SenderRole::kSlave, bus.MakePort(slave_node)),
        dof(dof_count) {
    bus.SetSleeper([this](std::uint64_t until_ns) { SleepUntil(static_cast<std::int64_t>(until_ns)); });
  }

  std::int64_t now() const { return static_cast<std::int64_t>(clock.now_ns); }

  /// Advances the clock to `until_ns`, stopping early at the master's next send (a wake-up, as a real sleep
  /// would see the frames arrive).
  void SleepUntil(std::int64_t until_ns) {
    if (master_every_ns > 0 && next_master_send_ns <= until_ns) {
      clock.now_ns = static_cast<std::uint64_t>(std::max(now(), next_master_send_ns));
      SendMasterCycle();
      next_master_send_ns += master_every_ns;
      return;
    }
    clock.now_ns = static_cast<std::uint64_t>(std::max(now(), until_ns));
  }

  /// The master's cycle `master_sequence`, of which only frames_sent(...) frames are put on the bus.
  void SendMasterCycle() {
    const std::uint32_t sequence = master_sequence++;
    std::array<CanFrame, proto::can::kMaxSlots> frames{};
    const int count =
        proto::can::EncodeCycle(test::MakeSample(SenderRole::kMaster, dof, sequence), Format(dof), frames).frames;
    const int sent = frames_sent(sequence, count);
    for (int i = 0; i < sent; ++i) (void)bus.Submit(master_node, frames[static_cast<std::size_t>(i)]);
  }
};

/// What PeriodicLoop::RunTriggered does between cycles, on the rig's clock: wait for the earliest start, wait on
/// the trigger until the schedule's deadline, start the cycle (poll the link) either way.
struct TriggeredLoop {
  runtime::TriggerSchedule schedule;
  std::uint64_t cycles = 0;
  std::uint64_t samples = 0;
  std::uint64_t torn = 0;

  explicit TriggeredLoop(std::int64_t start_ns)
      : schedule(runtime::TriggerSchedule::Config{kPeriod_ns, kPeriod_ns / 4, kPeriod_ns / 2}) {
    schedule.Start(start_ns);
  }

  void RunUntil(Rig& rig, std::int64_t end_ns) {
    while (rig.now() < end_ns) {
      while (rig.now() < schedule.earliest_start_ns()) rig.SleepUntil(schedule.earliest_start_ns());
      const bool fired = rig.slave.WaitReadable(schedule.deadline_ns());
      (void)schedule.CycleStarted(rig.now(), fired);
      ++cycles;
      proto::SampleMessage sample{};
      if (rig.slave.Poll(sample)) {
        ++samples;
        if (!test::ConsistentSample(sample)) ++torn;
      }
    }
  }
};

TEST(CanTrigger, FiresWhenTheLastFrameOfTheMastersCycleHasArrivedNotTheFirst) {
  for (const int dof : {1, 3, 6}) {
    SCOPED_TRACE(dof);
    Rig rig(dof);
    rig.clock.now_ns = 5'000'000;
    const std::int64_t sent_at = rig.now();
    ASSERT_TRUE(rig.master.Send(test::MakeSample(SenderRole::kMaster, dof, 7)));
    // Back to back on an idle bus: the cycle is whole at the end of its last frame.
    std::int64_t last_frame_end = sent_at;
    for (int slot = 0; slot < proto::can::SlotCount(dof); ++slot) {
      last_frame_end += FrameNs(proto::can::SlotLength(slot, dof));
    }
    ASSERT_TRUE(rig.slave.WaitReadable(sent_at + kPeriod_ns));
    EXPECT_EQ(rig.now(), last_frame_end) << "the trigger fires at the end of the cycle's last frame";
    if (dof > 1) {
      EXPECT_GT(rig.now(), sent_at + FrameNs(proto::can::SlotLength(0, dof))) << "not at the end of the first";
    }
    // The wait read the frames; Poll hands the sample back, stamped with the last frame's arrival.
    proto::SampleMessage out{};
    ASSERT_TRUE(rig.slave.Poll(out));
    EXPECT_EQ(out.sequence, 7u);
    EXPECT_TRUE(test::ConsistentSample(out));
    EXPECT_EQ(rig.slave.newest_receive_time_ns(), last_frame_end);
    EXPECT_EQ(rig.slave.counters().accepted, 1u);
    EXPECT_EQ(rig.slave.counters().received, 1u) << "one completed cycle, counted once";
    // Nothing more: no trigger, and the wait ends at its deadline, not before, not after.
    const std::int64_t deadline = rig.now() + kPeriod_ns;
    EXPECT_FALSE(rig.slave.WaitReadable(deadline));
    EXPECT_EQ(rig.now(), deadline);
    EXPECT_FALSE(rig.slave.Poll(out));
  }
}

TEST(CanTrigger, ADeadlineInThePastLooksOnceWithoutWaiting) {
  Rig rig(3);
  rig.clock.now_ns = 1'000'000;
  EXPECT_FALSE(rig.slave.WaitReadable(0));
  EXPECT_EQ(rig.now(), 1'000'000) << "no time passed";
  ASSERT_TRUE(rig.master.Send(test::MakeSample(SenderRole::kMaster, 3, 1)));
  rig.clock.now_ns += 10 * kPeriod_ns;  // the frames have long arrived
  EXPECT_TRUE(rig.slave.WaitReadable(0)) << "a complete sample already there fires the spin's look";
  proto::SampleMessage out{};
  EXPECT_TRUE(rig.slave.Poll(out));
}

TEST(CanTrigger, AMissingLastFrameIsATimeoutCountedAndTheCycleRunsAnyway) {
  Rig rig(3);  // 2 frames per cycle
  // The master's first frame only: the cycle never completes.
  rig.frames_sent = [](std::uint32_t, int) { return 1; };
  rig.master_every_ns = kPeriod_ns;
  rig.next_master_send_ns = rig.now() + kPeriod_ns / 10;
  const std::int64_t deadline = rig.now() + kPeriod_ns;
  EXPECT_FALSE(rig.slave.WaitReadable(deadline));
  EXPECT_EQ(rig.now(), deadline) << "waited to the deadline, no longer";
  EXPECT_GE(rig.slave.can_counters().frames_received, 1u) << "the first frame arrived and was read";

  // In the loop: every cycle times out, every cycle still runs (free-running at the nominal period), and the
  // partial cycles are counted, never applied.
  TriggeredLoop loop(rig.now());
  rig.next_master_send_ns = rig.now() + kPeriod_ns / 10;
  loop.RunUntil(rig, rig.now() + 50 * kPeriod_ns);
  EXPECT_EQ(loop.schedule.triggered(), 0u);
  EXPECT_EQ(loop.schedule.timeouts(), loop.cycles);
  EXPECT_GE(loop.cycles, 49u) << "a timeout runs the cycle: about one per period";
  EXPECT_LE(loop.cycles, 51u);
  EXPECT_EQ(loop.samples, 0u);
  EXPECT_GE(rig.slave.can_counters().partial_cycles, 40u);
  EXPECT_EQ(rig.slave.counters().accepted, 0u);
}

TEST(CanTrigger, EveryFifthCycleIncompleteGivesExactlyThoseTimeouts) {
  Rig rig(6);  // 4 frames per cycle
  rig.frames_sent = [](std::uint32_t sequence, int frames) { return sequence % 5 == 4 ? frames - 1 : frames; };
  rig.master_every_ns = kPeriod_ns;
  rig.next_master_send_ns = rig.now() + kPeriod_ns / 10;
  TriggeredLoop loop(rig.now());
  loop.RunUntil(rig, rig.now() + 100 * kPeriod_ns);
  const std::uint64_t incomplete = rig.master_sequence / 5;
  EXPECT_EQ(loop.schedule.triggered() + loop.schedule.timeouts(), loop.cycles);
  EXPECT_NEAR(static_cast<double>(loop.schedule.timeouts()), static_cast<double>(incomplete), 1.0);
  EXPECT_NEAR(static_cast<double>(loop.schedule.triggered()), static_cast<double>(rig.master_sequence - incomplete),
              1.0);
  EXPECT_EQ(loop.torn, 0u) << "a sample never mixes two cycles";
  EXPECT_EQ(rig.slave.counters().accepted, loop.samples);
}

TEST(CanTrigger, AFloodOfValidCyclesCannotRunTheSlaveFasterThanTheMinimumSpacing) {
  Rig rig(1);  // 115 µs per cycle: a master at 8 cycles per period keeps the bus 92 % busy
  rig.master_every_ns = kPeriod_ns / 8;
  rig.next_master_send_ns = rig.now();
  TriggeredLoop loop(rig.now());
  const std::int64_t start = rig.now();
  loop.RunUntil(rig, start + 100 * kPeriod_ns);
  EXPECT_GE(rig.master_sequence, 790u) << "the flood was sent";
  EXPECT_LE(loop.cycles, 201u) << "at most one cycle per half period (min_spacing)";
  EXPECT_GE(loop.schedule.triggered(), 190u) << "the flood's samples still start the cycles";
  EXPECT_EQ(loop.torn, 0u);
}

TEST(CanTrigger, RepeatedCyclesForeignAndMalformedFramesNeverFireIt) {
  Rig rig(3);
  ASSERT_TRUE(rig.master.Send(test::MakeSample(SenderRole::kMaster, 3, 3)));
  ASSERT_TRUE(rig.slave.WaitReadable(rig.now() + kPeriod_ns));
  proto::SampleMessage out{};
  ASSERT_TRUE(rig.slave.Poll(out));
  // A node replays the same cycle (duplicates), sends the slave's own identifiers (unknown to the slave), and a
  // frame of the wrong length, again and again (30 frames: about 4 ms of bus time).
  std::array<CanFrame, proto::can::kMaxSlots> replay{};
  ASSERT_EQ(proto::can::EncodeCycle(test::MakeSample(SenderRole::kMaster, 3, 3), Format(3), replay).frames, 2);
  std::array<CanFrame, proto::can::kMaxSlots> foreign{};
  ASSERT_EQ(proto::can::EncodeCycle(test::MakeSample(SenderRole::kSlave, 3, 4), Format(3), foreign).frames, 2);
  CanFrame short_frame = replay[0];
  short_frame.len = 3;
  for (int i = 0; i < 6; ++i) {
    (void)rig.bus.Submit(rig.rogue_node, replay[0]);
    (void)rig.bus.Submit(rig.rogue_node, replay[1]);
    (void)rig.bus.Submit(rig.rogue_node, foreign[0]);
    (void)rig.bus.Submit(rig.rogue_node, foreign[1]);
    (void)rig.bus.Submit(rig.rogue_node, short_frame);
  }
  const std::int64_t deadline = rig.now() + 10 * kPeriod_ns;
  EXPECT_FALSE(rig.slave.WaitReadable(deadline));
  EXPECT_EQ(rig.now(), deadline);
  EXPECT_FALSE(rig.slave.Poll(out));
  EXPECT_EQ(rig.slave.can_counters().frames_received, 2u + 30u) << "every frame was read during the wait";
  const LinkCounters& c = rig.slave.counters();
  EXPECT_GE(c.duplicates, 1u);
  EXPECT_GE(c.rejected, 6u + 6u) << "foreign identifiers and bad lengths, each counted";
  EXPECT_EQ(c.accepted, 1u);
  EXPECT_EQ(c.received, c.accepted + c.superseded + c.reordered + c.duplicates + c.rejected);
}

TEST(CanTrigger, WaitingAndPollingAllocateNothing) {
  Rig rig(3);
  rig.master_every_ns = kPeriod_ns;
  rig.next_master_send_ns = rig.now() + kPeriod_ns / 10;
  TriggeredLoop loop(rig.now());
  loop.RunUntil(rig, rig.now() + 5 * kPeriod_ns);  // warm up
  ::teleop::test::AllocationCounter counter;
  loop.RunUntil(rig, rig.now() + 100 * kPeriod_ns);
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_GE(loop.schedule.triggered(), 95u);
}

}  // namespace
}  // namespace teleop::transport
