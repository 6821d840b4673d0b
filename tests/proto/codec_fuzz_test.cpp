// Seeded mutation "fuzz" of valid datagrams. Nothing may crash (run the debug preset to get ASan/UBSan), and a
// mutated datagram is accepted only when its CRC still matches its content. CRC-32C has Hamming distance 6 up to
// 5243 data bits (Koopman), so every mutation of 1..5 flipped bits in a ≤ 184-byte datagram must be rejected.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <random>
#include <vector>

#include "proto/property_count.hpp"
#include "teleop/proto/codec.hpp"
#include "teleop/proto/crc.hpp"

namespace teleop::proto {
namespace {

using Bytes = std::vector<std::uint8_t>;

SampleMessage RandomValidMessage(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  SampleMessage m;
  m.sender = (rng() & 1) != 0 ? SenderRole::kSlave : SenderRole::kMaster;
  m.flags = static_cast<std::uint8_t>(rng() & kKnownFlags);
  m.dof = static_cast<std::uint8_t>(1 + rng() % kMaxWireDof);
  m.sequence = static_cast<std::uint32_t>(rng());
  m.sender_time_ns = rng();
  m.echo_time_ns = rng();
  m.echo_age_ns = static_cast<std::uint32_t>(rng());
  for (std::size_t i = 0; i < m.dof; ++i) {
    m.position_m[i] = unit(rng) * kMaxAbsPosition_m;
    m.velocity_m_per_s[i] = unit(rng) * kMaxAbsVelocity_m_per_s;
    m.force_N[i] = unit(rng) * kMaxAbsForce_N;
  }
  return m;
}

Bytes Encode(const SampleMessage& m) {
  Bytes out(MaxEncodedSampleSize());
  out.resize(EncodeSample(m, out));
  return out;
}

bool CrcMatches(const Bytes& b) {
  if (b.size() < wire::kCrcSize) return false;
  const std::size_t at = b.size() - wire::kCrcSize;
  std::uint32_t stored = 0;
  for (std::size_t i = 0; i < 4; ++i) stored |= static_cast<std::uint32_t>(b[at + i]) << (8 * i);
  return stored == Crc32c(std::span<const std::uint8_t>(b).first(at));
}

TEST(CodecFuzz, FewBitFlipsAreAlwaysRejected) {
  const int count = test::PropertyCount(20000);
  std::mt19937_64 rng(1);
  std::array<int, static_cast<std::size_t>(DecodeStatus::kCount)> by_status{};
  for (int n = 0; n < count; ++n) {
    Bytes b = Encode(RandomValidMessage(rng));
    const Bytes original = b;
    const int flips = 1 + static_cast<int>(rng() % 5);
    for (int f = 0; f < flips; ++f) {
      const std::size_t bit = rng() % (b.size() * 8);
      b[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
    if (b == original) continue;  // two flips of the same bit cancel
    SampleMessage out;
    const DecodeStatus status = DecodeSample(b, out);
    ASSERT_NE(status, DecodeStatus::kOk) << "case " << n << " with " << flips << " flips accepted";
    ++by_status[static_cast<std::size_t>(status)];
  }
  // Most flips land in the payload and are caught by the CRC; flips in the leading header bytes are caught earlier.
  EXPECT_GT(by_status[static_cast<std::size_t>(DecodeStatus::kBadCrc)], count / 2);
  EXPECT_GT(by_status[static_cast<std::size_t>(DecodeStatus::kBadMagic)], 0);
}

TEST(CodecFuzz, TruncationAndExtensionAreRejectedBySize) {
  const int count = test::PropertyCount(5000);
  std::mt19937_64 rng(2);
  for (int n = 0; n < count; ++n) {
    const Bytes valid = Encode(RandomValidMessage(rng));
    SampleMessage out;
    const Bytes truncated(valid.begin(), valid.begin() + static_cast<std::ptrdiff_t>(rng() % valid.size()));
    ASSERT_EQ(DecodeSample(truncated, out), DecodeStatus::kTooShort) << truncated.size();
    Bytes extended = valid;
    const std::size_t extra = 1 + rng() % 64;
    for (std::size_t i = 0; i < extra; ++i) extended.push_back(static_cast<std::uint8_t>(rng()));
    ASSERT_EQ(DecodeSample(extended, out), DecodeStatus::kBadLength);
  }
}

// Heavier damage: random byte overwrites, random lengths, and pure noise. Accepted only if the CRC matches.
TEST(CodecFuzz, ArbitraryDamageIsAcceptedOnlyWithAMatchingCrc) {
  const int count = test::PropertyCount(20000);
  std::mt19937_64 rng(3);
  int accepted = 0;
  for (int n = 0; n < count; ++n) {
    Bytes b;
    Bytes original;
    switch (rng() % 3) {
      case 0: {  // overwrite a run of bytes of a valid datagram
        b = Encode(RandomValidMessage(rng));
        original = b;
        const std::size_t start = rng() % b.size();
        const std::size_t len = 1 + rng() % 16;
        for (std::size_t i = start; i < b.size() && i < start + len; ++i) b[i] = static_cast<std::uint8_t>(rng());
        break;
      }
      case 1: {  // valid header, random length, random tail
        b = Encode(RandomValidMessage(rng));
        b.resize(wire::kHeaderSize + rng() % 200);
        for (std::size_t i = wire::kHeaderSize; i < b.size(); ++i) b[i] = static_cast<std::uint8_t>(rng());
        break;
      }
      default: {  // noise
        b.resize(rng() % 300);
        for (auto& x : b) x = static_cast<std::uint8_t>(rng());
        break;
      }
    }
    SampleMessage out;
    if (DecodeSample(b, out) == DecodeStatus::kOk) {
      ASSERT_TRUE(CrcMatches(b)) << "case " << n;
      if (b != original) ++accepted;  // an overwrite may write back the same bytes
    }
  }
  // With a 32-bit CRC, a random acceptance is a ~2^-32 event per case: none expected at any sane count.
  EXPECT_EQ(accepted, 0);
}

}  // namespace
}  // namespace teleop::proto
