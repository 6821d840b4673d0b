#include "teleop/proto/codec.hpp"

#include <cmath>

#include "little_endian.hpp"
#include "teleop/proto/crc.hpp"

namespace teleop::proto {
namespace {

using little_endian::GetF64;
using little_endian::GetU16;
using little_endian::GetU32;
using little_endian::GetU64;
using little_endian::PutF64;
using little_endian::PutU16;
using little_endian::PutU32;
using little_endian::PutU64;
using little_endian::PutU8;

bool ValidDof(int dof) noexcept { return dof >= 1 && dof <= kMaxWireDof; }

// kNonFinite wins over kOutOfRange for a field that is both (NaN compares false with everything).
DecodeStatus CheckValue(double value, double max_abs) noexcept {
  if (!std::isfinite(value)) return DecodeStatus::kNonFinite;
  if (std::fabs(value) > max_abs) return DecodeStatus::kOutOfRange;
  return DecodeStatus::kOk;
}

}  // namespace

const char* ToString(SenderRole role) noexcept {
  switch (role) {
    case SenderRole::kMaster:
      return "master";
    case SenderRole::kSlave:
      return "slave";
  }
  return "invalid";
}

const char* ToString(DecodeStatus status) noexcept {
  switch (status) {
    case DecodeStatus::kOk:
      return "ok";
    case DecodeStatus::kTooShort:
      return "too_short";
    case DecodeStatus::kBadMagic:
      return "bad_magic";
    case DecodeStatus::kBadVersion:
      return "bad_version";
    case DecodeStatus::kBadType:
      return "bad_type";
    case DecodeStatus::kBadDof:
      return "bad_dof";
    case DecodeStatus::kBadLength:
      return "bad_length";
    case DecodeStatus::kBadCrc:
      return "bad_crc";
    case DecodeStatus::kNonFinite:
      return "non_finite";
    case DecodeStatus::kOutOfRange:
      return "out_of_range";
    case DecodeStatus::kCount:
      break;
  }
  return "invalid";
}

std::size_t MaxEncodedSampleSize() noexcept { return kMaxEncodedSampleBytes; }

std::size_t EncodedSampleSize(int dof, bool has_energy) noexcept {
  if (!ValidDof(dof)) return 0;
  const std::size_t per_dof = wire::kBytesPerDof + (has_energy ? wire::kEnergyBytesPerDof : 0);
  return wire::kHeaderSize + static_cast<std::size_t>(dof) * per_dof + wire::kCrcSize;
}

DecodeStatus ValidateSample(const SampleMessage& message) noexcept {
  if (message.sender != SenderRole::kMaster && message.sender != SenderRole::kSlave) {
    return DecodeStatus::kOutOfRange;
  }
  if ((message.flags & ~kKnownFlags) != 0) return DecodeStatus::kOutOfRange;
  if (!ValidDof(message.dof)) return DecodeStatus::kBadDof;
  // Non-finite anywhere is reported before out-of-range anywhere, so one NaN is always kNonFinite.
  DecodeStatus worst = DecodeStatus::kOk;
  for (std::size_t i = 0; i < message.dof; ++i) {
    for (const DecodeStatus s : {CheckValue(message.position_m[i], kMaxAbsPosition_m),
                                 CheckValue(message.velocity_m_per_s[i], kMaxAbsVelocity_m_per_s),
                                 CheckValue(message.force_N[i], kMaxAbsForce_N)}) {
      if (s == DecodeStatus::kNonFinite) return s;
      if (s != DecodeStatus::kOk) worst = s;
    }
    if (message.has_energy) {
      for (const double e : {message.input_energy_J[i], message.output_energy_J[i]}) {
        if (!std::isfinite(e)) return DecodeStatus::kNonFinite;
        if (e < 0.0 || e > kMaxEnergy_J) worst = DecodeStatus::kOutOfRange;
      }
    }
  }
  return worst;
}

std::size_t EncodeSample(const SampleMessage& message, std::span<std::uint8_t> out) noexcept {
  const std::size_t size = EncodedSampleSize(message.dof, message.has_energy);
  if (size == 0 || out.size() < size) return 0;
  std::uint8_t* p = out.data();
  PutU32(p + wire::kMagicOffset, wire::kMagic);
  PutU8(p + wire::kVersionOffset, kProtocolVersion);
  PutU8(p + wire::kTypeOffset, static_cast<std::uint8_t>(MessageType::kSample));
  PutU8(p + wire::kSenderOffset, static_cast<std::uint8_t>(message.sender));
  PutU8(p + wire::kFlagsOffset, message.flags);
  PutU8(p + wire::kDofOffset, message.dof);
  PutU8(p + wire::kReservedOffset, 0);
  PutU16(p + wire::kPayloadLengthOffset, static_cast<std::uint16_t>(size - wire::kHeaderSize - wire::kCrcSize));
  PutU32(p + wire::kSequenceOffset, message.sequence);
  PutU64(p + wire::kSenderTimeOffset, message.sender_time_ns);
  PutU64(p + wire::kEchoTimeOffset, message.echo_time_ns);
  PutU32(p + wire::kEchoAgeOffset, message.echo_age_ns);
  std::uint8_t* q = p + wire::kHeaderSize;
  for (std::size_t i = 0; i < message.dof; ++i, q += wire::kBytesPerDof) {
    PutF64(q, message.position_m[i]);
    PutF64(q + 8, message.velocity_m_per_s[i]);
    PutF64(q + 16, message.force_N[i]);
  }
  if (message.has_energy) {
    for (std::size_t i = 0; i < message.dof; ++i, q += wire::kEnergyBytesPerDof) {
      PutF64(q, message.input_energy_J[i]);
      PutF64(q + 8, message.output_energy_J[i]);
    }
  }
  const std::size_t crc_offset = size - wire::kCrcSize;
  PutU32(p + crc_offset, Crc32c(out.first(crc_offset)));
  return size;
}

DecodeStatus DecodeSample(std::span<const std::uint8_t> bytes, SampleMessage& out) noexcept {
  if (bytes.size() < wire::kHeaderSize) return DecodeStatus::kTooShort;
  const std::uint8_t* p = bytes.data();
  if (GetU32(p + wire::kMagicOffset) != wire::kMagic) return DecodeStatus::kBadMagic;
  if (p[wire::kVersionOffset] != kProtocolVersion) return DecodeStatus::kBadVersion;
  if (p[wire::kTypeOffset] != static_cast<std::uint8_t>(MessageType::kSample)) return DecodeStatus::kBadType;
  const int dof = p[wire::kDofOffset];
  if (!ValidDof(dof)) return DecodeStatus::kBadDof;
  const std::size_t values = static_cast<std::size_t>(dof) * wire::kBytesPerDof;
  const std::size_t with_energy = values + static_cast<std::size_t>(dof) * wire::kEnergyBytesPerDof;
  const std::size_t payload = GetU16(p + wire::kPayloadLengthOffset);
  if (payload != values && payload != with_energy) return DecodeStatus::kBadLength;
  const std::size_t size = wire::kHeaderSize + payload + wire::kCrcSize;
  if (bytes.size() < size) return DecodeStatus::kTooShort;
  if (bytes.size() > size) return DecodeStatus::kBadLength;
  const std::size_t crc_offset = size - wire::kCrcSize;
  if (GetU32(p + crc_offset) != Crc32c(bytes.first(crc_offset))) return DecodeStatus::kBadCrc;
  if (p[wire::kReservedOffset] != 0) return DecodeStatus::kOutOfRange;

  SampleMessage m{};
  m.sender = static_cast<SenderRole>(p[wire::kSenderOffset]);
  m.flags = p[wire::kFlagsOffset];
  m.dof = static_cast<std::uint8_t>(dof);
  m.sequence = GetU32(p + wire::kSequenceOffset);
  m.sender_time_ns = GetU64(p + wire::kSenderTimeOffset);
  m.echo_time_ns = GetU64(p + wire::kEchoTimeOffset);
  m.echo_age_ns = GetU32(p + wire::kEchoAgeOffset);
  const std::uint8_t* q = p + wire::kHeaderSize;
  for (std::size_t i = 0; i < m.dof; ++i, q += wire::kBytesPerDof) {
    m.position_m[i] = GetF64(q);
    m.velocity_m_per_s[i] = GetF64(q + 8);
    m.force_N[i] = GetF64(q + 16);
  }
  m.has_energy = payload == with_energy;
  if (m.has_energy) {
    for (std::size_t i = 0; i < m.dof; ++i, q += wire::kEnergyBytesPerDof) {
      m.input_energy_J[i] = GetF64(q);
      m.output_energy_J[i] = GetF64(q + 8);
    }
  }
  const DecodeStatus status = ValidateSample(m);
  if (status != DecodeStatus::kOk) return status;
  out = m;
  return DecodeStatus::kOk;
}

}  // namespace teleop::proto
