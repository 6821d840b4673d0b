// CanLink over the in-process emulated bus: a bilateral exchange, every kind of bad input counted by reason and
// never applied, error frames and bus-off as a link fault, the bus-load refusal, no allocation in the cycle.
#include "teleop/transport/can_link.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "can_test_helpers.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/can_bus_budget.hpp"
#include "teleop/transport/can_emulated_bus.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::transport {
namespace {

using proto::DecodeStatus;
using proto::SenderRole;
using proto::can::CanFrame;

constexpr std::uint64_t kPeriod_ns = 1'000'000;  // 1 kHz

proto::can::CanWireFormat Format(int dof, bool fd = false) {
  proto::can::CanWireFormat f{};
  f.dof = dof;
  f.fd = fd;
  return f;
}

struct Rig {
  test::ManualClock clock;
  EmulatedCanBus bus;
  int master_node, slave_node, rogue_node;
  CanLink master, slave;

  explicit Rig(proto::can::CanWireFormat format = Format(3))
      : bus(EmulatedCanBusConfig{}, [this] { return clock.now_ns; }),
        master_node(bus.AddNode()),
        slave_node(bus.AddNode()),
        rogue_node(bus.AddNode()),
        master(format, SenderRole::kMaster, bus.MakePort(master_node)),
        slave(format, SenderRole::kSlave, bus.MakePort(slave_node)) {}

  void Rogue(const CanFrame& frame) { ASSERT_EQ(bus.Submit(rogue_node, frame), CanWriteStatus::kOk); }
  /// Frames the master would send for `sequence`.
  std::array<CanFrame, proto::can::kMaxSlots> MasterFrames(std::uint32_t sequence, int dof = 3) {
    std::array<CanFrame, proto::can::kMaxSlots> frames{};
    proto::can::CanWireFormat f = Format(dof);
    EXPECT_EQ(proto::can::EncodeCycle(test::MakeSample(SenderRole::kMaster, dof, sequence), f, frames).frames,
              proto::can::FramesPerCycle(f));
    return frames;
  }
};

void ExpectBalanced(const LinkCounters& c) {
  EXPECT_EQ(c.received, c.accepted + c.superseded + c.reordered + c.duplicates + c.rejected);
  std::uint64_t by_reason = 0;
  for (const std::uint64_t n : c.rejected_by_reason) by_reason += n;
  EXPECT_EQ(c.rejected, by_reason + c.wrong_sender);
}

TEST(CanLink, BilateralExchangeAtOneKilohertz) {
  for (const bool fd : {false, true}) {
    Rig rig(Format(3, fd));
    proto::SampleMessage at_slave{}, at_master{};
    int slave_got = 0, master_got = 0;
    for (std::uint32_t s = 0; s < 100; ++s) {
      ASSERT_TRUE(rig.master.Send(test::MakeSample(SenderRole::kMaster, 3, 1000 + s)));
      ASSERT_TRUE(rig.slave.Send(test::MakeSample(SenderRole::kSlave, 3, 5 + s)));
      rig.clock.now_ns += kPeriod_ns;
      if (rig.slave.Poll(at_slave)) {
        ++slave_got;
        EXPECT_TRUE(test::ConsistentSample(at_slave));
        EXPECT_EQ(at_slave.sender, SenderRole::kMaster);
      }
      if (rig.master.Poll(at_master)) {
        ++master_got;
        EXPECT_TRUE(test::ConsistentSample(at_master));
      }
    }
    EXPECT_EQ(slave_got, 100);
    EXPECT_EQ(master_got, 100);
    // The 4-bit wire counter extends back to a sequence that follows the sender's (first one taken as is).
    EXPECT_EQ(at_slave.sequence % 16, (1000u + 99u) % 16);
    EXPECT_EQ(at_master.sequence, 5u + 99u);
    EXPECT_EQ(rig.slave.counters().lost, 0u);
    EXPECT_EQ(rig.slave.counters().rejected, 0u);
    EXPECT_EQ(rig.slave.can_counters().frames_received, fd ? 100u : 200u);
    ExpectBalanced(rig.slave.counters());
    // Measured bus load: both directions, 2 × 270 µs per 1 ms classic (54 %), 2 × 72.6 µs FD.
    const double load = static_cast<double>(rig.bus.stats().busy_ns) / (100.0 * kPeriod_ns);
    EXPECT_NEAR(load, fd ? 0.1452 : 0.54, 1e-3);
  }
}

TEST(CanLink, LossIsCountedFromTheExtendedCounter) {
  Rig rig;
  proto::SampleMessage out{};
  for (std::uint32_t s = 0; s < 40; ++s) {
    if (s % 5 != 4) {
      ASSERT_TRUE(rig.master.Send(test::MakeSample(SenderRole::kMaster, 3, s)));
    }
    rig.clock.now_ns += kPeriod_ns;
    (void)rig.slave.Poll(out);
  }
  EXPECT_EQ(rig.slave.counters().lost, 7u);  // 4, 9, ..., 34 (39 is not followed by anything yet)
  EXPECT_EQ(rig.slave.counters().accepted, 32u);
}

TEST(CanLink, EveryBadInputIsCountedByReasonAndNeverApplied) {
  Rig rig;
  proto::SampleMessage out{};
  out.sequence = 0xDEAD;
  auto poll_nothing = [&] {
    rig.clock.now_ns += kPeriod_ns;
    EXPECT_FALSE(rig.slave.Poll(out));
    EXPECT_EQ(out.sequence, 0xDEADu);
  };
  // Unknown identifier.
  CanFrame unknown{};
  unknown.id = 0x555;
  unknown.len = 8;
  rig.Rogue(unknown);
  poll_nothing();
  EXPECT_EQ(rig.slave.counters().rejected_by_reason[static_cast<std::size_t>(DecodeStatus::kBadMagic)], 1u);
  // Wrong DLC on a peer identifier.
  auto frames = rig.MasterFrames(1);
  CanFrame short_frame = frames[1];
  short_frame.len = 5;
  rig.Rogue(short_frame);
  poll_nothing();
  EXPECT_EQ(rig.slave.counters().rejected_by_reason[static_cast<std::size_t>(DecodeStatus::kBadLength)], 1u);
  // FD frame where classic is configured.
  CanFrame fd = frames[0];
  fd.fd = true;
  rig.Rogue(fd);
  poll_nothing();
  EXPECT_EQ(rig.slave.counters().rejected_by_reason[static_cast<std::size_t>(DecodeStatus::kBadType)], 1u);
  // Partial cycle: slot 0 of cycle 2 only, then cycle 3 complete: 3 applied, 2 dropped as partial.
  rig.Rogue(rig.MasterFrames(2)[0]);
  frames = rig.MasterFrames(3);
  rig.Rogue(frames[0]);
  rig.Rogue(frames[1]);
  rig.clock.now_ns += kPeriod_ns;
  ASSERT_TRUE(rig.slave.Poll(out));
  EXPECT_TRUE(test::ConsistentSample(out));
  EXPECT_EQ(out.sequence % 16, 3u);
  EXPECT_EQ(rig.slave.can_counters().partial_cycles, 1u);
  EXPECT_EQ(rig.slave.counters().rejected_by_reason[static_cast<std::size_t>(DecodeStatus::kTooShort)], 1u);
  // Repeated counter: cycle 3 again → duplicate, not applied.
  out.sequence = 0xDEAD;
  rig.Rogue(frames[0]);
  rig.Rogue(frames[1]);
  poll_nothing();
  EXPECT_EQ(rig.slave.counters().duplicates, 1u);
  // Stale counter: cycle 1 after 3 → reordered, not applied.
  rig.Rogue(rig.MasterFrames(1)[0]);
  rig.Rogue(rig.MasterFrames(1)[1]);
  poll_nothing();
  EXPECT_EQ(rig.slave.counters().reordered, 1u);
  // Duplicate frame inside a cycle.
  frames = rig.MasterFrames(4);
  rig.Rogue(frames[0]);
  rig.Rogue(frames[0]);
  rig.Rogue(frames[1]);
  rig.clock.now_ns += kPeriod_ns;
  ASSERT_TRUE(rig.slave.Poll(out));
  EXPECT_EQ(out.sequence % 16, 4u);
  EXPECT_EQ(
      rig.slave.can_counters().frames_by_status[static_cast<std::size_t>(proto::can::FrameStatus::kDuplicateFrame)],
      1u);
  // NaN from the peer: the cycle is dropped.
  proto::SampleMessage nan_sample = test::MakeSample(SenderRole::kMaster, 3, 5);
  nan_sample.force_N[2] = std::nan("");
  std::array<CanFrame, proto::can::kMaxSlots> nan_frames{};
  ASSERT_EQ(proto::can::EncodeCycle(nan_sample, Format(3), nan_frames).non_finite, 1);
  rig.Rogue(nan_frames[0]);
  rig.Rogue(nan_frames[1]);
  out.sequence = 0xDEAD;
  poll_nothing();
  EXPECT_EQ(rig.slave.counters().rejected_by_reason[static_cast<std::size_t>(DecodeStatus::kNonFinite)], 1u);
  ExpectBalanced(rig.slave.counters());
  EXPECT_NE(rig.slave.Summary().find("partial cycles 1"), std::string::npos) << rig.slave.Summary();
}

// A peer of an older build sends CAN layout 1 (6-bit Flags, no layout marker): its cycles are refused, counted as
// bad_version (the UDP sample's reason for another protocol version) and named old_layout in the summary.
TEST(CanLink, APeerOfTheOldLayoutIsRefusedAsBadVersion) {
  for (const int dof : {1, 3}) {
    SCOPED_TRACE(dof);
    Rig rig(Format(dof));
    proto::SampleMessage out{};
    out.sequence = 0xDEAD;
    // The 3-DOF cycle of CAN layout 1 (the golden frames of the previous layout), and the 1-DOF one (6 bytes).
    CanFrame slot0{};
    slot0.id = 0x100;
    slot0.len = dof == 1 ? 6 : 8;
    const std::array<std::uint8_t, 8> old0{0x15, 0xC9, 0x00, 0xFE, 0xB7, 0x84, 0xFF, 0x1F};
    std::copy(old0.begin(), old0.begin() + slot0.len, slot0.data.begin());
    if (dof == 1) slot0.data[5] = 0x04;
    CanFrame slot1{};
    slot1.id = 0x101;
    slot1.len = 8;
    const std::array<std::uint8_t, 8> old1{0x15, 0x80, 0x00, 0xFC, 0xFF, 0x00, 0x10, 0x00};
    std::copy(old1.begin(), old1.end(), slot1.data.begin());
    for (int cycle = 0; cycle < 5; ++cycle) {
      rig.Rogue(slot0);
      if (dof == 3) rig.Rogue(slot1);
      rig.clock.now_ns += kPeriod_ns;
      EXPECT_FALSE(rig.slave.Poll(out));
    }
    EXPECT_EQ(out.sequence, 0xDEADu) << "never applied";
    EXPECT_EQ(rig.slave.counters().accepted, 0u);
    EXPECT_EQ(rig.slave.counters().rejected_by_reason[static_cast<std::size_t>(DecodeStatus::kBadVersion)], 5u);
    EXPECT_EQ(rig.slave.can_counters().frames_by_status[static_cast<std::size_t>(proto::can::FrameStatus::kOldLayout)],
              5u);
    EXPECT_NE(rig.slave.Summary().find("old_layout 5"), std::string::npos) << rig.slave.Summary();
    ExpectBalanced(rig.slave.counters());
  }
}

TEST(CanLink, ErrorFramesAreCountedAndBusOffIsALinkFault) {
  Rig rig;
  proto::SampleMessage out{};
  rig.bus.InjectErrors(2);
  ASSERT_TRUE(rig.master.Send(test::MakeSample(SenderRole::kMaster, 3, 1)));
  rig.clock.now_ns += kPeriod_ns;
  ASSERT_TRUE(rig.slave.Poll(out));  // retransmitted after the errors
  EXPECT_EQ(rig.slave.counters().bus_errors, 2u);
  EXPECT_EQ(rig.slave.can_counters().protocol_errors, 2u);

  rig.bus.ForceBusOff(rig.master_node);
  EXPECT_FALSE(rig.master.Poll(out));
  EXPECT_TRUE(rig.master.bus_off());
  EXPECT_EQ(rig.master.can_counters().bus_off, 1u);
  EXPECT_FALSE(rig.master.Send(test::MakeSample(SenderRole::kMaster, 3, 2)));
  EXPECT_EQ(rig.master.counters().send_errors, 1u);
  EXPECT_NE(rig.master.Summary().find("LINK FAULT: bus-off"), std::string::npos);
  rig.bus.Restart(rig.master_node);
  EXPECT_FALSE(rig.master.Poll(out));
  EXPECT_FALSE(rig.master.bus_off());
  EXPECT_TRUE(rig.master.Send(test::MakeSample(SenderRole::kMaster, 3, 3)));
}

TEST(CanLink, ResynchronisesAfterPeerRestart) {
  Rig rig;
  proto::SampleMessage out{};
  std::uint32_t s = 0;
  for (; s < 20; ++s) {
    ASSERT_TRUE(rig.master.Send(test::MakeSample(SenderRole::kMaster, 3, 100 + s)));
    rig.clock.now_ns += kPeriod_ns;
    ASSERT_TRUE(rig.slave.Poll(out));
  }
  // The master restarts at sequence 8 (which reads as 8 behind): stale at first, then re-tracked.
  int accepted_after_restart = 0;
  for (std::uint32_t r = 0; r < 10; ++r) {
    ASSERT_TRUE(rig.master.Send(test::MakeSample(SenderRole::kMaster, 3, (100 + s + 8) + r)));
    rig.clock.now_ns += kPeriod_ns;
    accepted_after_restart += rig.slave.Poll(out) ? 1 : 0;
  }
  EXPECT_GE(accepted_after_restart, 10 - CanLink::kResyncAfter);
  EXPECT_EQ(rig.slave.can_counters().resyncs, 1u);
}

TEST(CanLink, SendRefusesWrongDofAndFullQueue) {
  Rig rig;
  EXPECT_FALSE(rig.master.Send(test::MakeSample(SenderRole::kMaster, 2, 0)));
  EXPECT_EQ(rig.master.counters().send_errors, 1u);
  // 32 frames of queue, 2 per cycle, nothing drains while the clock stands still (the frame on the wire keeps its
  // place until its transmission ends): 16 cycles fit, the other 4 are refused at their first frame.
  int refused = 0;
  for (std::uint32_t s = 0; s < 20; ++s)
    refused += rig.master.Send(test::MakeSample(SenderRole::kMaster, 3, s)) ? 0 : 1;
  EXPECT_EQ(refused, 4);
  EXPECT_EQ(rig.master.can_counters().tx_buffer_full, 4u);
  EXPECT_EQ(rig.master.can_counters().frames_sent, 32u);
  EXPECT_EQ(rig.master.counters().sent, 16u);
  EXPECT_EQ(rig.master.counters().send_errors, 1u + 4u);  // the wrong-DOF send and the 4 refused cycles
}

TEST(CanLink, SendAndPollDoNotAllocate) {
  Rig rig(Format(6));
  proto::SampleMessage out{};
  const proto::SampleMessage sample = test::MakeSample(SenderRole::kMaster, 6, 0);
  int got = 0;
  ::teleop::test::AllocationCounter counter;
  for (std::uint32_t s = 0; s < 100; ++s) {
    proto::SampleMessage m = sample;
    m.sequence = s;
    got += rig.master.Send(m) ? 1 : 0;
    rig.clock.now_ns += kPeriod_ns;
    got += rig.slave.Poll(out) ? 1 : 0;
  }
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_EQ(got, 200);
}

TEST(CanBusBudget, RefusesAboveTheLimitWithTheNumbers) {
  CanLinkConfig config;
  config.dof = 4;
  config.medium = CanMedium::kEmulatedBus;
  try {
    (void)MakeCanLink(config, SenderRole::kMaster, 1000.0);
    FAIL() << "4 DOF classic at 1 kHz (77 %) must be refused";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bus load 77.0 %"), std::string::npos) << what;
    EXPECT_NE(what.find("limit 70.0 %"), std::string::npos) << what;
    EXPECT_NE(what.find("385 bits"), std::string::npos) << what;
  }
  config.dof = 3;
  EXPECT_NEAR(CheckCanBusBudget(config, 1000.0).load, 0.54, 1e-12);
  config.max_bus_load = 0.5;
  EXPECT_THROW(CheckCanBusBudget(config, 1000.0), Error);
  config.max_bus_load = 0.7;
  config.fd = true;
  config.dof = 6;
  EXPECT_NEAR(CheckCanBusBudget(config, 3000.0).load, 2 * (34e-6 + 358 / 5e6) * 3000.0, 1e-12);  // FD: 6 DOF, 3 kHz
  EXPECT_THROW(CheckCanBusBudget(config, 4000.0), Error);                                        // 84.5 %
  config.slave_to_master_base_id = config.master_to_slave_base_id + 2;
  EXPECT_THROW(CheckCanBusBudget(config, 1000.0), Error);
  config.slave_to_master_base_id = 0x180;
  config.dof = 13;  // beyond CAN FD's 12 (classic: 6)
  EXPECT_THROW(CheckCanBusBudget(config, 1000.0), Error);
}

}  // namespace
}  // namespace teleop::transport
