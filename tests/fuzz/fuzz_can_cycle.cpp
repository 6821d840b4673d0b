// libFuzzer harness: the CAN frame decode and cycle reassembly (proto/can/sample_codec.cpp, CycleAssembler). The
// first input byte picks the wire format (dof 1..6 classic or 1..12 FD, 11- or 29-bit identifiers); the rest is a
// stream of frames, each: a control byte (bit 0 extended, 1 FD, 2 BRS, 3 remote, 4 error, 5 Tick() after it,
// 6 Reset() after it), an identifier byte (offset from the peer's base, so most frames hit the peer's identifiers),
// a length byte, then that many data bytes. Properties: no crash or UB; every status is in range; a completed
// cycle is a valid sample of the configured dof from the peer; and an encoded cycle always reassembles to itself
// within the documented quantization.
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "fuzz_check.hpp"
#include "teleop/proto/can/sample_codec.hpp"
#include "teleop/proto/codec.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace teleop::proto;
  using namespace teleop::proto::can;
  if (size == 0) return 0;
  CanWireFormat format{};
  format.fd = (data[0] & 0x10) != 0;
  format.dof = 1 + (data[0] & 0x0F) % (format.fd ? kMaxWireDof : kMaxClassicDof);  // classic 1..6, FD 1..12
  format.extended_id = (data[0] & 0x20) != 0;
  TELEOP_FUZZ_CHECK(CheckFormat(format) == FormatStatus::kOk);
  const SenderRole peer = (data[0] & 0x40) != 0 ? SenderRole::kSlave : SenderRole::kMaster;
  CycleAssembler assembler(format, peer);

  std::size_t i = 1;
  std::uint32_t sequence = 0;
  while (i + 3 <= size) {
    const std::uint8_t control = data[i];
    CanFrame frame{};
    frame.extended = (control & 0x01) != 0;
    frame.fd = (control & 0x02) != 0;
    frame.brs = (control & 0x04) != 0;
    frame.remote = (control & 0x08) != 0;
    frame.error = (control & 0x10) != 0;
    frame.id = (BaseIdOf(format, peer) + data[i + 1]) & (frame.extended ? kMaxExtendedId : kMaxStandardId);
    frame.error_class = data[i + 1];
    const std::size_t len = data[i + 2] % (kFdMaxDataBytes + 1);
    frame.len = static_cast<std::uint8_t>(len);
    i += 3;
    for (std::size_t k = 0; k < len && i < size; ++k, ++i) frame.data[k] = data[i];
    SampleMessage sample{};
    sample.dof = 0;
    const FrameStatus status = assembler.Push(frame, sample);
    TELEOP_FUZZ_CHECK(status < FrameStatus::kCount && ToString(status) != nullptr);
    if (status == FrameStatus::kComplete) {
      TELEOP_FUZZ_CHECK(sample.sender == peer);
      TELEOP_FUZZ_CHECK(sample.dof == format.dof);
      TELEOP_FUZZ_CHECK(sample.sequence < kCounterModulo);
      TELEOP_FUZZ_CHECK((sample.flags & ~kKnownFlags) == 0);
      for (int d = 0; d < format.dof; ++d) {
        TELEOP_FUZZ_CHECK(std::isfinite(sample.position_m[d]) && std::isfinite(sample.velocity_m_per_s[d]) &&
                          std::isfinite(sample.force_N[d]));
      }
      sequence = ExtendCounter(sequence, static_cast<std::uint8_t>(sample.sequence));
      TELEOP_FUZZ_CHECK((sequence & 0xF) == sample.sequence);
    }
    if ((control & 0x20) != 0) assembler.Tick();
    if ((control & 0x40) != 0) assembler.Reset();
    TELEOP_FUZZ_CHECK(assembler.partial_cycles() >= 0 && assembler.partial_cycles() <= CycleAssembler::kAssemblies);
  }

  // Round trip: the input's bytes as values, encoded and reassembled by a fresh assembler.
  SampleMessage sent{};
  sent.sender = peer;
  sent.dof = static_cast<std::uint8_t>(format.dof);
  sent.flags = static_cast<std::uint8_t>(data[size - 1] & kKnownFlags);  // the 7-bit CAN Flags signal (layout 2)
  sent.sequence = static_cast<std::uint32_t>(size);
  for (int d = 0; d < format.dof; ++d) {
    const auto byte = [&](std::size_t k) {
      return static_cast<double>(data[(k * 7 + static_cast<std::size_t>(d)) % size]) - 128.0;
    };
    sent.position_m[d] = byte(1) * 1e-3;         // ±0.128 m, inside ±0.1638 m
    sent.velocity_m_per_s[d] = byte(2) * 0.015;  // ±1.92 m/s, inside ±2.046 m/s
    sent.force_N[d] = byte(3) * 0.15;            // ±19.2 N, inside ±20.47 N
  }
  std::array<CanFrame, kMaxSlots> frames{};
  const EncodeResult encoded = EncodeCycle(sent, format, frames);
  TELEOP_FUZZ_CHECK(encoded.frames == FramesPerCycle(format) && encoded.saturated == 0 && encoded.non_finite == 0);
  CycleAssembler fresh(format, peer);
  SampleMessage got{};
  FrameStatus last = FrameStatus::kPending;
  for (int f = 0; f < encoded.frames; ++f) last = fresh.Push(frames[f], got);
  TELEOP_FUZZ_CHECK(last == FrameStatus::kComplete);
  TELEOP_FUZZ_CHECK(got.flags == sent.flags && got.sequence == (sent.sequence & 0xF));
  for (int d = 0; d < format.dof; ++d) {
    TELEOP_FUZZ_CHECK(std::fabs(got.position_m[d] - sent.position_m[d]) <= kPositionScaling.lsb / 2 + 1e-12);
    TELEOP_FUZZ_CHECK(std::fabs(got.velocity_m_per_s[d] - sent.velocity_m_per_s[d]) <=
                      kVelocityScaling.lsb / 2 + 1e-12);
    TELEOP_FUZZ_CHECK(std::fabs(got.force_N[d] - sent.force_N[d]) <= kForceScaling.lsb / 2 + 1e-12);
  }
  return 0;
}
