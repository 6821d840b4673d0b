// The bus-load budget (proto/can/bus_load.hpp) against numbers computed by hand in docs/can.md.
#include <gtest/gtest.h>

#include "teleop/proto/can/bus_load.hpp"
#include "teleop/proto/can/frame_layout.hpp"

namespace teleop::proto::can {
namespace {

constexpr double kTol = 1e-12;

CanWireFormat Format(int dof, bool fd = false, bool extended = false) {
  CanWireFormat f{};
  f.dof = dof;
  f.fd = fd;
  f.extended_id = extended;
  return f;
}

TEST(CanBusLoad, ClassicFrameBitsWorstCaseStuffing) {
  EXPECT_EQ(ClassicFrameBits(false, 0), 55);
  EXPECT_EQ(ClassicFrameBits(false, 6), 115);
  EXPECT_EQ(ClassicFrameBits(false, 8), 135);
  EXPECT_EQ(ClassicFrameBits(true, 0), 80);
  EXPECT_EQ(ClassicFrameBits(true, 8), 160);
}

TEST(CanBusLoad, FdFrameBitsFromFieldSizes) {
  // 11-bit, 16 bytes. Nominal: head 17 + floor(16/4)=4 stuff + tail 13 = 34.
  // Data: ESI+DLC+128 = 133, dynamic stuff floor((17+133-1)/4) - 4 = 33, stuff count 4, CRC-17, 6 fixed = 193.
  FdFrameBits b = FdFrameBitsWorstCase(false, 16);
  EXPECT_EQ(b.nominal, 34);
  EXPECT_EQ(b.data, 193);
  // 11-bit, 32 bytes: data 5+256 = 261, stuff floor(277/4) - 4 = 65, 4, CRC-21, 7 fixed = 358.
  b = FdFrameBitsWorstCase(false, 32);
  EXPECT_EQ(b.nominal, 34);
  EXPECT_EQ(b.data, 358);
  // 29-bit, 16 bytes: head 36 + floor(35/4)=8 + 13 = 57; data 133 + (floor(168/4) - 8 = 34) + 4 + 17 + 6 = 194.
  b = FdFrameBitsWorstCase(true, 16);
  EXPECT_EQ(b.nominal, 57);
  EXPECT_EQ(b.data, 194);
  CanBitrates rates{1e6, 5e6};
  EXPECT_NEAR(FrameTime_s(true, true, false, 16, rates), 34e-6 + 193.0 / 5e6, kTol);
  EXPECT_NEAR(FrameTime_s(true, false, false, 16, rates), (34.0 + 193.0) / 1e6, kTol);  // no bit-rate switch
  EXPECT_NEAR(FrameTime_s(false, false, false, 8, rates), 135e-6, kTol);
}

TEST(CanBusLoad, ThreeDofClassicAtOneKilohertzIs54Percent) {
  const BusLoad b = ComputeBusLoad(Format(3), CanBitrates{1e6, 5e6}, 1000.0);
  EXPECT_EQ(b.frames_per_cycle, 2);
  EXPECT_EQ(b.data_bytes_per_cycle, 16);
  EXPECT_EQ(b.wire_bits_per_cycle, 270);      // 2 × (55 + 80)
  EXPECT_EQ(b.payload_bits, 3 * 37 + 7 + 4);  // 122 bits → 16 bytes → 2 frames at least
  EXPECT_EQ(b.minimum_bits_per_cycle, 270);
  EXPECT_NEAR(b.overhead, 1.0, kTol);
  EXPECT_NEAR(b.load, 2 * 270e-6 * 1000.0, kTol);  // 0.54
}

TEST(CanBusLoad, FourDofClassicExceedsSeventyPercent) {
  const BusLoad b = ComputeBusLoad(Format(4), CanBitrates{1e6, 5e6}, 1000.0);
  EXPECT_EQ(b.wire_bits_per_cycle, 135 + 135 + 115);  // 8 + 8 + 6 bytes
  EXPECT_NEAR(b.load, 0.770, kTol);
  // Minimum: 159 payload bits → 20 bytes → 3 frames: 3·55 + 10·20 = 365.
  EXPECT_EQ(b.minimum_bits_per_cycle, 365);
  EXPECT_NEAR(b.overhead, 385.0 / 365.0, kTol);
  EXPECT_EQ(MaxDofWithinLoad(Format(1), CanBitrates{1e6, 5e6}, 1000.0, 0.70, 64), 3);
  // A triggered slave's wait on the bus: one 8-byte frame of the other direction already on the wire, then the
  // cycle's three frames.
  EXPECT_NEAR(b.longest_frame_s, 135e-6, kTol);
  EXPECT_NEAR(b.cycle_complete_s, (135 + 385) * 1e-6, kTol);
}

TEST(CanBusLoad, TwoDofOverheadAgainstMinimum) {
  const BusLoad b = ComputeBusLoad(Format(2), CanBitrates{}, 1000.0);
  EXPECT_EQ(b.wire_bits_per_cycle, 135 + 95);      // 8 + 4 bytes
  EXPECT_EQ(b.minimum_bits_per_cycle, 110 + 110);  // 85 bits → 11 bytes in 2 frames
  EXPECT_NEAR(b.overhead, 230.0 / 220.0, kTol);
}

// The layout marker makes the 1-DOF frame 7 bytes: 55 + 70 = 125 bits against the 6-byte minimum of its 48 payload
// bits (115), the one DOF count whose frames the marker lengthens.
TEST(CanBusLoad, OneDofClassicPaysOneByteForTheLayoutMarker) {
  const BusLoad b = ComputeBusLoad(Format(1), CanBitrates{1e6, 5e6}, 1000.0);
  EXPECT_EQ(b.frames_per_cycle, 1);
  EXPECT_EQ(b.data_bytes_per_cycle, 7);
  EXPECT_EQ(b.wire_bits_per_cycle, 125);
  EXPECT_EQ(b.payload_bits, 37 + 7 + 4);
  EXPECT_EQ(b.minimum_bits_per_cycle, 115);
  EXPECT_NEAR(b.overhead, 125.0 / 115.0, kTol);
  EXPECT_NEAR(b.load, 0.25, kTol);
}

TEST(CanBusLoad, FdThreeDofAtOneFiveMegabit) {
  const BusLoad b = ComputeBusLoad(Format(3, true), CanBitrates{1e6, 5e6}, 1000.0);
  EXPECT_EQ(b.frames_per_cycle, 1);
  EXPECT_EQ(b.data_bytes_per_cycle, 16);
  EXPECT_NEAR(b.wire_time_per_cycle_s, 34e-6 + 193.0 / 5e6, kTol);
  EXPECT_NEAR(b.load, 2 * (34e-6 + 193.0 / 5e6) * 1000.0, kTol);  // 0.1452
  EXPECT_NEAR(b.overhead, 1.0, kTol);
  EXPECT_NEAR(b.cycle_complete_s, 2 * (34e-6 + 193.0 / 5e6), kTol) << "FD: the one frame, blocked by the peer's";
}

TEST(CanBusLoad, ExtendedIdsCostTwentyFiveBitsMorePerFrame) {
  const BusLoad b = ComputeBusLoad(Format(3, false, true), CanBitrates{}, 1000.0);
  EXPECT_EQ(b.wire_bits_per_cycle, 320);
  EXPECT_NEAR(b.load, 0.64, kTol);
}

TEST(CanBusLoad, OverheadWithinTenPercentForEveryWireDof) {
  for (const bool fd : {false, true}) {
    for (int dof = 1; dof <= (fd ? kMaxWireDof : kMaxClassicDof); ++dof) {
      for (const bool ext : {false, true}) {
        const BusLoad b = ComputeBusLoad(Format(dof, fd, ext), CanBitrates{1e6, 5e6}, 1000.0);
        EXPECT_GE(b.overhead, 1.0 - kTol) << dof << fd << ext;
        // One exception, CAN FD at 10 DOF: its 54 data bytes need a 64-byte frame (the FD lengths step from 48 to
        // 64), where the 380 payload bits alone would fit 48 bytes: 1.23x (11-bit), 1.20x (29-bit) by the
        // worst-case stuffing formula; 11 and 12 DOF fill the 64 bytes again (docs/can.md).
        const double bound = fd && dof == 10 ? (ext ? 1.20 : 1.233) : 1.1;
        EXPECT_LE(b.overhead, bound) << dof << fd << ext;
      }
    }
  }
}

TEST(CanBusLoad, InvalidInputGivesZeroes) {
  EXPECT_EQ(ComputeBusLoad(Format(0), CanBitrates{}, 1000.0).load, 0.0);
  EXPECT_EQ(ComputeBusLoad(Format(3), CanBitrates{}, 0.0).load, 0.0);
  EXPECT_EQ(ComputeBusLoad(Format(3), CanBitrates{0.0, 5e6}, 1000.0).load, 0.0);
}

}  // namespace
}  // namespace teleop::proto::can
