// The CAN frame codec (proto/can): golden frames, saturation, NaN, round trips, reassembly that never mixes cycles,
// and every kind of bad frame rejected by reason.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "teleop/proto/can/sample_codec.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::proto::can {
namespace {

constexpr double kPosTol_m = 10e-6 + 1e-12;  // half an LSB
constexpr double kVelTol_m_per_s = 1e-3 + 1e-12;
constexpr double kForceTol_N = 5e-3 + 1e-12;

SampleMessage GoldenSample() {
  SampleMessage m{};
  m.sender = SenderRole::kMaster;
  m.flags = kFlagEnabled | kFlagInFixture;
  m.dof = 3;
  m.sequence = 0x12345;  // counter 5
  m.position_m = {0.001, -0.00002, 0.16382, 0, 0, 0};
  m.velocity_m_per_s = {-0.004, 0.002, 0.0, 0, 0, 0};
  m.force_N = {1.5, -20.47, 0.01, 0, 0, 0};
  return m;
}

CanWireFormat Format(int dof, bool fd = false) {
  CanWireFormat f{};
  f.dof = dof;
  f.fd = fd;
  return f;
}

std::vector<CanFrame> Encode(const SampleMessage& m, const CanWireFormat& f, EncodeResult* result = nullptr) {
  std::vector<CanFrame> frames(kMaxSlots);
  const EncodeResult r = EncodeCycle(m, f, frames);
  frames.resize(static_cast<std::size_t>(r.frames));
  if (result != nullptr) *result = r;
  return frames;
}

std::vector<std::uint8_t> Bytes(const CanFrame& f) { return {f.data.begin(), f.data.begin() + f.len}; }

TEST(CanCodec, GoldenClassicFramesThreeDof) {
  const auto frames = Encode(GoldenSample(), Format(3));
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].id, 0x100u);
  EXPECT_EQ(frames[1].id, 0x101u);
  EXPECT_FALSE(frames[0].fd);
  EXPECT_FALSE(frames[0].extended);
  // Computed independently (Python, bit by bit from the table in docs/can.md: layout 2, the layout marker bit 62).
  EXPECT_EQ(Bytes(frames[0]), (std::vector<std::uint8_t>{0x15, 0x91, 0x01, 0xFC, 0x6F, 0x09, 0xFF, 0x7F}));
  EXPECT_EQ(Bytes(frames[1]), (std::vector<std::uint8_t>{0x15, 0x80, 0x00, 0xFC, 0xFF, 0x00, 0x10, 0x00}));
}

TEST(CanCodec, GoldenOneDofIsOneSevenByteFrame) {
  SampleMessage m = GoldenSample();
  m.dof = 1;
  const auto frames = Encode(m, Format(1));
  ASSERT_EQ(frames.size(), 1u);
  // 48 bits of signals, then the layout marker (bit 48): 7 bytes (layout 1 sent 6).
  EXPECT_EQ(Bytes(frames[0]), (std::vector<std::uint8_t>{0x15, 0x91, 0x01, 0xFC, 0x6F, 0x09, 0x01}));
}

// kFlagClutched (bit 6) crosses CAN in the 7-bit Flags signal (bits 4..10), classic and FD, as over UDP.
TEST(CanCodec, GoldenClutchedFramesCarryFlagBitSix) {
  SampleMessage m = GoldenSample();
  m.flags = kFlagEnabled | kFlagInFixture | kFlagClutched;  // 0x51
  const auto frames = Encode(m, Format(3));
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(Bytes(frames[0]), (std::vector<std::uint8_t>{0x15, 0x95, 0x01, 0xFC, 0x6F, 0x09, 0xFF, 0x7F}));
  EXPECT_EQ(Bytes(frames[1]), (std::vector<std::uint8_t>{0x15, 0x80, 0x00, 0xFC, 0xFF, 0x00, 0x10, 0x00}));
  CycleAssembler rx(Format(3), SenderRole::kMaster);
  SampleMessage out{};
  ASSERT_EQ(rx.Push(frames[0], out), FrameStatus::kPending);
  ASSERT_EQ(rx.Push(frames[1], out), FrameStatus::kComplete);
  EXPECT_EQ(out.flags, kFlagEnabled | kFlagInFixture | kFlagClutched);

  SampleMessage one = GoldenSample();
  one.dof = 1;
  one.flags = kFlagEnabled | kFlagClutched;  // 0x41
  const auto one_frames = Encode(one, Format(1));
  ASSERT_EQ(one_frames.size(), 1u);
  EXPECT_EQ(Bytes(one_frames[0]), (std::vector<std::uint8_t>{0x15, 0x94, 0x01, 0xFC, 0x6F, 0x09, 0x01}));

  m.sender = SenderRole::kSlave;
  const auto fd = Encode(m, Format(3, true));
  ASSERT_EQ(fd.size(), 1u);
  EXPECT_EQ(Bytes(fd[0]), (std::vector<std::uint8_t>{0x15, 0x95, 0x01, 0xFC, 0x6F, 0x09, 0xFF, 0x7F, 0x15, 0x80, 0x00,
                                                     0xFC, 0xFF, 0x00, 0x10, 0x00}));
  CycleAssembler rx_fd(Format(3, true), SenderRole::kSlave);
  ASSERT_EQ(rx_fd.Push(fd[0], out), FrameStatus::kComplete);
  EXPECT_EQ(out.flags, kFlagEnabled | kFlagInFixture | kFlagClutched);
}

// Frames of CAN layout 1 (6-bit Flags, no layout marker; the golden bytes this test pinned before layout 2) are
// refused as old_layout, never misread as shifted fields.
TEST(CanRejection, Layout1FramesAreRefusedAsOldLayout) {
  SampleMessage out{};
  out.sequence = 777;
  CycleAssembler rx3(Format(3), SenderRole::kMaster);
  CanFrame slot0{};
  slot0.id = 0x100;
  slot0.len = 8;
  const std::array<std::uint8_t, 8> old0{0x15, 0xC9, 0x00, 0xFE, 0xB7, 0x84, 0xFF, 0x1F};
  std::copy(old0.begin(), old0.end(), slot0.data.begin());
  CanFrame slot1{};
  slot1.id = 0x101;
  slot1.len = 8;
  const std::array<std::uint8_t, 8> old1{0x15, 0x80, 0x00, 0xFC, 0xFF, 0x00, 0x10, 0x00};
  std::copy(old1.begin(), old1.end(), slot1.data.begin());
  EXPECT_EQ(rx3.Push(slot0, out), FrameStatus::kOldLayout);
  EXPECT_EQ(rx3.Push(slot1, out), FrameStatus::kPending);  // slot 1 has no marker: its cycle never completes
  EXPECT_EQ(out.sequence, 777u);

  CycleAssembler rx1(Format(1), SenderRole::kMaster);
  CanFrame one{};
  one.id = 0x100;
  one.len = 6;
  const std::array<std::uint8_t, 6> old_one{0x15, 0xC9, 0x00, 0xFE, 0xB7, 0x04};
  std::copy(old_one.begin(), old_one.end(), one.data.begin());
  EXPECT_EQ(rx1.Push(one, out), FrameStatus::kOldLayout);

  CycleAssembler rx_fd(Format(3, true), SenderRole::kSlave);
  CanFrame fd{};
  fd.id = 0x184;
  fd.fd = true;
  fd.brs = true;
  fd.len = 16;
  std::copy(old0.begin(), old0.end(), fd.data.begin());
  std::copy(old1.begin(), old1.end(), fd.data.begin() + 8);
  EXPECT_EQ(rx_fd.Push(fd, out), FrameStatus::kOldLayout);
  CycleAssembler rx_fd1(Format(1, true), SenderRole::kSlave);
  CanFrame fd1 = one;
  fd1.id = 0x184;
  fd1.fd = true;
  EXPECT_EQ(rx_fd1.Push(fd1, out), FrameStatus::kOldLayout);
  EXPECT_EQ(out.sequence, 777u);  // untouched
  EXPECT_STREQ(ToString(FrameStatus::kOldLayout), "old_layout");
}

TEST(CanCodec, GoldenFdFrameIsTheSlotsConcatenated) {
  SampleMessage m = GoldenSample();
  m.sender = SenderRole::kSlave;
  const auto frames = Encode(m, Format(3, true));
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].id, 0x184u);
  EXPECT_TRUE(frames[0].fd);
  EXPECT_TRUE(frames[0].brs);
  EXPECT_EQ(Bytes(frames[0]), (std::vector<std::uint8_t>{0x15, 0x91, 0x01, 0xFC, 0x6F, 0x09, 0xFF, 0x7F, 0x15, 0x80,
                                                         0x00, 0xFC, 0xFF, 0x00, 0x10, 0x00}));
}

TEST(CanCodec, SlotCountsAndLengthsPerDof) {
  const std::array<int, 6> slots{1, 2, 2, 3, 4, 4};
  const std::array<std::vector<int>, 6> lengths{{{7}, {8, 4}, {8, 8}, {8, 8, 6}, {8, 8, 8, 4}, {8, 8, 8, 8}}};
  const std::array<int, 6> fd_len{7, 12, 16, 24, 32, 32};
  for (int dof = 1; dof <= 6; ++dof) {
    const auto i = static_cast<std::size_t>(dof - 1);
    EXPECT_EQ(SlotCount(dof), slots[i]) << dof;
    for (int k = 0; k < slots[i]; ++k) EXPECT_EQ(SlotLength(k, dof), lengths[i][static_cast<std::size_t>(k)]);
    EXPECT_EQ(RoundUpToFdLength(static_cast<std::size_t>(FdDataBytes(dof))), static_cast<std::size_t>(fd_len[i]));
  }
}

TEST(CanCodec, SaturatesInsteadOfWrapping) {
  SampleMessage m = GoldenSample();
  m.position_m[0] = 1.0;  // far above +0.16382 m
  m.velocity_m_per_s[1] = -7.0;
  m.force_N[2] = 1e6;
  EncodeResult r{};
  const auto frames = Encode(m, Format(3), &r);
  EXPECT_EQ(r.saturated, 3);
  EXPECT_EQ(r.non_finite, 0);
  CycleAssembler rx(Format(3), SenderRole::kMaster);
  SampleMessage out{};
  EXPECT_EQ(rx.Push(frames[0], out), FrameStatus::kPending);
  ASSERT_EQ(rx.Push(frames[1], out), FrameStatus::kComplete);
  EXPECT_NEAR(out.position_m[0], 0.16382, 1e-12);  // the largest code, same sign
  EXPECT_NEAR(out.velocity_m_per_s[1], -2.046, 1e-12);
  EXPECT_NEAR(out.force_N[2], 20.47, 1e-12);
  bool saturated = true;
  EXPECT_EQ(Quantize(0.16382, kPositionScaling, saturated), 8191);
  EXPECT_FALSE(saturated);
  EXPECT_EQ(Quantize(0.1639, kPositionScaling, saturated), 8191);
  EXPECT_TRUE(saturated);
  EXPECT_EQ(Quantize(-1e9, kForceScaling, saturated), -2047);  // never -2048: that code means NaN
  EXPECT_TRUE(saturated);
}

TEST(CanCodec, NonFiniteFieldDropsTheWholeCycle) {
  SampleMessage m = GoldenSample();
  m.force_N[1] = std::nan("");
  m.velocity_m_per_s[2] = std::numeric_limits<double>::infinity();
  EncodeResult r{};
  const auto frames = Encode(m, Format(3), &r);
  EXPECT_EQ(r.non_finite, 2);
  CycleAssembler rx(Format(3), SenderRole::kMaster);
  SampleMessage out{};
  out.sequence = 777;
  EXPECT_EQ(rx.Push(frames[0], out), FrameStatus::kPending);
  EXPECT_EQ(rx.Push(frames[1], out), FrameStatus::kNonFinite);
  EXPECT_EQ(out.sequence, 777u);  // untouched
}

// Seeded property test: random in-range samples survive classic and FD encoding within half an LSB.
// Classic CAN stops at 6 DOF (4 slots, identifiers base + 0..3; base + 4 is the FD frame's), CAN FD at 12 (8 slots,
// one 64-byte frame); beyond either the format is refused and nothing is encoded (docs/can.md).
TEST(CanCodec, ClassicCarriesUpToSixDofAndFdUpToTwelve) {
  EXPECT_EQ(CheckFormat(Format(6, false)), FormatStatus::kOk);
  EXPECT_EQ(CheckFormat(Format(7, false)), FormatStatus::kBadDof);
  EXPECT_EQ(FramesPerCycle(Format(7, false)), 0);
  EXPECT_EQ(CheckFormat(Format(12, true)), FormatStatus::kOk);
  EXPECT_EQ(FramesPerCycle(Format(12, true)), 1);
  EXPECT_EQ(FdDataBytes(12), 64);
  EXPECT_EQ(SlotCount(12), kMaxSlots);
  EXPECT_EQ(CheckFormat(Format(13, true)), FormatStatus::kBadDof);
  SampleMessage m{};
  m.dof = 7;
  std::array<CanFrame, kMaxSlots> frames{};
  EXPECT_EQ(EncodeCycle(m, Format(7, false), frames).frames, 0);
  const EncodeResult fd = EncodeCycle(m, Format(7, true), frames);
  ASSERT_EQ(fd.frames, 1);
  EXPECT_EQ(frames[0].len, 48);  // 8 x 4 + 6 data bytes, rounded up to an FD length
  EXPECT_EQ(frames[0].id, 0x100u + kFdIdOffset);
  CycleAssembler classic(Format(7, false), SenderRole::kMaster);
  SampleMessage out{};
  CanFrame f{};
  f.id = 0x100;
  f.len = 8;
  EXPECT_EQ(classic.Push(f, out), FrameStatus::kBadFormat);
}

TEST(CanCodec, RoundTripWithinHalfLsbAllDofBothFormats) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> pos(-0.16, 0.16), vel(-2.0, 2.0), force(-20.0, 20.0);
  constexpr int kSamplesPerCase = 200;  // raise for a longer run
  for (int dof = 1; dof <= kMaxWireDof; ++dof) {
    for (const bool fd : {false, true}) {
      if (!fd && dof > kMaxClassicDof) continue;  // classic CAN carries 1..6 (FramesPerCycle 0 beyond)
      const CanWireFormat f = Format(dof, fd);
      CycleAssembler rx(f, SenderRole::kSlave);
      for (int i = 0; i < kSamplesPerCase; ++i) {
        SampleMessage m{};
        m.sender = SenderRole::kSlave;
        m.dof = static_cast<std::uint8_t>(dof);
        m.flags = static_cast<std::uint8_t>(rng() & kKnownFlags);  // bits 0..6, kFlagClutched included
        m.sequence = static_cast<std::uint32_t>(i);
        for (int d = 0; d < dof; ++d) {
          const auto j = static_cast<std::size_t>(d);
          m.position_m[j] = pos(rng);
          m.velocity_m_per_s[j] = vel(rng);
          m.force_N[j] = force(rng);
        }
        const auto frames = Encode(m, f);
        ASSERT_EQ(frames.size(), static_cast<std::size_t>(FramesPerCycle(f)));
        SampleMessage out{};
        FrameStatus st = FrameStatus::kPending;
        for (const CanFrame& fr : frames) st = rx.Push(fr, out);
        ASSERT_EQ(st, FrameStatus::kComplete) << "dof " << dof << " fd " << fd;
        EXPECT_EQ(out.sequence, m.sequence % 16);
        EXPECT_EQ(out.flags, m.flags);
        EXPECT_EQ(out.dof, dof);
        EXPECT_EQ(out.sender, SenderRole::kSlave);
        for (int d = 0; d < dof; ++d) {
          const auto j = static_cast<std::size_t>(d);
          EXPECT_NEAR(out.position_m[j], m.position_m[j], kPosTol_m);
          EXPECT_NEAR(out.velocity_m_per_s[j], m.velocity_m_per_s[j], kVelTol_m_per_s);
          EXPECT_NEAR(out.force_N[j], m.force_N[j], kForceTol_N);
        }
      }
    }
  }
}

SampleMessage Cycle(std::uint32_t sequence, double value) {
  SampleMessage m{};
  m.sender = SenderRole::kMaster;
  m.dof = 3;
  m.sequence = sequence;
  for (std::size_t j = 0; j < 3; ++j) {
    m.position_m[j] = value;
    m.velocity_m_per_s[j] = value;
    m.force_N[j] = value;
  }
  return m;
}

bool AllFieldsNear(const SampleMessage& m, double value) {
  for (std::size_t j = 0; j < 3; ++j) {
    if (std::abs(m.position_m[j] - value) > kPosTol_m || std::abs(m.velocity_m_per_s[j] - value) > kVelTol_m_per_s ||
        std::abs(m.force_N[j] - value) > kForceTol_N) {
      return false;
    }
  }
  return true;
}

// Frames of two cycles interleaved (what a controller with several mailboxes does when slot 0 of the next cycle
// overtakes slot 1 of this one): each cycle is assembled from its own frames only.
TEST(CanReassembly, InterleavedCyclesNeverMix) {
  const auto a = Encode(Cycle(1, 0.1), Format(3));
  const auto b = Encode(Cycle(2, -0.1), Format(3));
  CycleAssembler rx(Format(3), SenderRole::kMaster);
  SampleMessage out{};
  EXPECT_EQ(rx.Push(a[0], out), FrameStatus::kPending);
  EXPECT_EQ(rx.Push(b[0], out), FrameStatus::kPending);
  ASSERT_EQ(rx.Push(a[1], out), FrameStatus::kComplete);
  EXPECT_EQ(out.sequence, 1u);
  EXPECT_TRUE(AllFieldsNear(out, 0.1));
  ASSERT_EQ(rx.Push(b[1], out), FrameStatus::kComplete);
  EXPECT_EQ(out.sequence, 2u);
  EXPECT_TRUE(AllFieldsNear(out, -0.1));
  EXPECT_EQ(rx.abandoned_partial_cycles(), 0u);
}

// Slot 1 of cycle 1 lost: cycle 2 completes from its own frames; cycle 1's partial is dropped and counted.
TEST(CanReassembly, PartialCycleIsDroppedAndCounted) {
  const auto a = Encode(Cycle(1, 0.1), Format(3));
  const auto b = Encode(Cycle(2, -0.1), Format(3));
  CycleAssembler rx(Format(3), SenderRole::kMaster);
  SampleMessage out{};
  EXPECT_EQ(rx.Push(a[0], out), FrameStatus::kPending);
  EXPECT_EQ(rx.Push(b[1], out), FrameStatus::kPending);  // b's slot 1 first: pending in its own buffer
  ASSERT_EQ(rx.Push(b[0], out), FrameStatus::kComplete);
  EXPECT_TRUE(AllFieldsNear(out, -0.1));
  EXPECT_EQ(rx.abandoned_partial_cycles(), 1u);  // a, older than the completed b
  EXPECT_EQ(rx.partial_cycles(), 0);
  // a's slot 1 arriving late starts a new buffer; it can never complete with a's lost slot 0.
  EXPECT_EQ(rx.Push(a[1], out), FrameStatus::kPending);
}

// After a pause of 16 cycles the counter comes round: a stale partial cycle must not be completed by a frame of a
// later cycle with the same counter.
TEST(CanReassembly, PartialCycleExpiresBeforeTheCounterComesRound) {
  const auto old_cycle = Encode(Cycle(3, 0.1), Format(3));
  const auto new_cycle = Encode(Cycle(3 + 16, -0.1), Format(3));
  CycleAssembler rx(Format(3), SenderRole::kMaster);
  SampleMessage out{};
  EXPECT_EQ(rx.Push(old_cycle[0], out), FrameStatus::kPending);
  for (std::uint64_t i = 0; i < CycleAssembler::kExpiryTicks; ++i) rx.Tick();
  EXPECT_EQ(rx.abandoned_partial_cycles(), 1u);
  EXPECT_EQ(rx.Push(new_cycle[1], out), FrameStatus::kPending);
  ASSERT_EQ(rx.Push(new_cycle[0], out), FrameStatus::kComplete);
  EXPECT_TRUE(AllFieldsNear(out, -0.1));
}

TEST(CanReassembly, OldestPartialEvictedWhenAllBuffersBusy) {
  CycleAssembler rx(Format(3), SenderRole::kMaster);
  SampleMessage out{};
  for (std::uint32_t c = 0; c < CycleAssembler::kAssemblies + 1; ++c) {
    EXPECT_EQ(rx.Push(Encode(Cycle(c, 0.0), Format(3))[0], out), FrameStatus::kPending);
  }
  EXPECT_EQ(rx.abandoned_partial_cycles(), 1u);
  EXPECT_EQ(rx.partial_cycles(), CycleAssembler::kAssemblies);
}

TEST(CanRejection, EveryBadFrameHasItsReason) {
  const CanWireFormat f = Format(3);
  const auto good = Encode(Cycle(1, 0.05), f);
  CycleAssembler rx(f, SenderRole::kMaster);
  SampleMessage out{};

  CanFrame unknown = good[0];
  unknown.id = 0x102;  // 3 DOF uses base + 0, 1 only
  EXPECT_EQ(rx.Push(unknown, out), FrameStatus::kUnknownId);
  unknown.id = 0x181;  // our own direction's identifier
  EXPECT_EQ(rx.Push(unknown, out), FrameStatus::kUnknownId);
  CanFrame ext = good[0];
  ext.extended = true;
  EXPECT_EQ(rx.Push(ext, out), FrameStatus::kUnknownId);

  CanFrame short_frame = good[1];
  short_frame.len = 7;
  EXPECT_EQ(rx.Push(short_frame, out), FrameStatus::kBadLength);

  CanFrame fd = good[0];
  fd.fd = true;
  EXPECT_EQ(rx.Push(fd, out), FrameStatus::kBadFormat);
  CanFrame remote = good[0];
  remote.remote = true;
  EXPECT_EQ(rx.Push(remote, out), FrameStatus::kBadFormat);
  CanFrame error{};
  error.error = true;
  EXPECT_EQ(rx.Push(error, out), FrameStatus::kBadFormat);

  SampleMessage one_dof = Cycle(1, 0.05);
  one_dof.dof = 1;
  CanWireFormat f1 = Format(1);
  CycleAssembler rx1(f1, SenderRole::kMaster);
  CanFrame reserved = Encode(one_dof, f1)[0];
  EXPECT_EQ(rx1.Push(reserved, out), FrameStatus::kComplete);
  reserved.data[6] |= 0x80;  // bit 55: reserved for 1 DOF (bits 49..55 after the marker)
  EXPECT_EQ(rx1.Push(reserved, out), FrameStatus::kReservedBits);
  CanFrame unmarked = Encode(one_dof, f1)[0];
  unmarked.data[6] = 0;  // the layout marker (bit 48) cleared: not layout 2
  EXPECT_EQ(rx1.Push(unmarked, out), FrameStatus::kOldLayout);

  EXPECT_EQ(rx.Push(good[0], out), FrameStatus::kPending);
  EXPECT_EQ(rx.Push(good[0], out), FrameStatus::kDuplicateFrame);
  EXPECT_EQ(rx.Push(good[1], out), FrameStatus::kComplete);
}

TEST(CanRejection, FdFrameChecks) {
  const CanWireFormat f = Format(4, true);
  SampleMessage m = Cycle(9, 0.02);
  m.dof = 4;
  m.position_m[3] = 0.03;
  const auto frames = Encode(m, f);
  ASSERT_EQ(frames.size(), 1u);
  ASSERT_EQ(frames[0].len, 24);  // 22 data bytes + 2 padding
  CycleAssembler rx(f, SenderRole::kMaster);
  SampleMessage out{};
  ASSERT_EQ(rx.Push(frames[0], out), FrameStatus::kComplete);
  EXPECT_NEAR(out.position_m[3], 0.03, kPosTol_m);

  CanFrame padding = frames[0];
  padding.data[23] = 0xCC;
  EXPECT_EQ(rx.Push(padding, out), FrameStatus::kReservedBits);
  CanFrame torn = frames[0];
  torn.data[8] = static_cast<std::uint8_t>((torn.data[8] & 0xF0) | 0x0A);  // slot 1 counter 10, slot 0 counter 9
  EXPECT_EQ(rx.Push(torn, out), FrameStatus::kCounterMismatch);
  CanFrame wrong_len = frames[0];
  wrong_len.len = 32;
  EXPECT_EQ(rx.Push(wrong_len, out), FrameStatus::kBadLength);
  CanFrame classic = frames[0];
  classic.fd = false;
  EXPECT_EQ(rx.Push(classic, out), FrameStatus::kBadFormat);
}

TEST(CanCodec, EncodeRefusesDofMismatchAndSmallBuffers) {
  SampleMessage m = GoldenSample();
  std::array<CanFrame, 4> frames{};
  EXPECT_EQ(EncodeCycle(m, Format(2), frames).frames, 0);
  EXPECT_EQ(EncodeCycle(m, Format(3), std::span<CanFrame>(frames).first(1)).frames, 0);
  CanWireFormat overlap = Format(3);
  overlap.slave_to_master_base_id = 0x102;
  EXPECT_EQ(CheckFormat(overlap), FormatStatus::kIdRangesOverlap);
  EXPECT_EQ(EncodeCycle(m, overlap, frames).frames, 0);
  CanWireFormat too_high = Format(3);
  too_high.master_to_slave_base_id = 0x7FC;
  EXPECT_EQ(CheckFormat(too_high), FormatStatus::kIdOutOfRange);
  too_high.extended_id = true;
  EXPECT_EQ(CheckFormat(too_high), FormatStatus::kOk);
}

TEST(CanCodec, ExtendCounterPicksTheNearestSequence) {
  EXPECT_EQ(ExtendCounter(100, 100 % 16), 100u);
  EXPECT_EQ(ExtendCounter(100, (100 + 7) % 16), 107u);
  EXPECT_EQ(ExtendCounter(100, (100 + 8) % 16), 92u);  // 8 ahead is read as 8 behind
  EXPECT_EQ(ExtendCounter(100, (100 - 3) % 16), 97u);
  EXPECT_EQ(ExtendCounter(0xFFFFFFFEu, 1), 1u);  // across the 32-bit wrap
  EXPECT_EQ(ExtendCounter(2, 15), 0xFFFFFFFFu);
}

TEST(CanCodec, EncodeAndReassembleDoNotAllocate) {
  const CanWireFormat f = Format(6);
  SampleMessage m = Cycle(4, 0.01);
  m.dof = 6;
  CycleAssembler rx(f, SenderRole::kMaster);
  std::array<CanFrame, kMaxSlots> frames{};
  SampleMessage out{};
  int complete = 0;
  test::AllocationCounter counter;
  for (std::uint32_t s = 0; s < 50; ++s) {
    m.sequence = s;
    const EncodeResult r = EncodeCycle(m, f, frames);
    for (int k = 0; k < r.frames; ++k)
      complete += rx.Push(frames[static_cast<std::size_t>(k)], out) == FrameStatus::kComplete;
    rx.Tick();
  }
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_EQ(complete, 50);
}

}  // namespace
}  // namespace teleop::proto::can
