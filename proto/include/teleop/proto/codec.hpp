#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "teleop/proto/sample_message.hpp"

namespace teleop::proto {

/// Result of decoding one datagram. Everything but kOk is a counted rejection.
enum class DecodeStatus : std::uint8_t {
  kOk = 0,
  kTooShort,    ///< Fewer bytes than the header, or than the header's dof needs.
  kBadMagic,    ///< Not a teleop datagram.
  kBadVersion,  ///< Another protocol version.
  kBadType,     ///< Unknown message type.
  kBadDof,      ///< dof of 0 or above kMaxWireDof.
  kBadLength,   ///< Length field disagrees with the dof, or the datagram is longer than the message.
  kBadCrc,      ///< CRC-32C mismatch.
  kNonFinite,   ///< NaN or infinity in a field.
  kOutOfRange,  ///< A field outside the documented range (docs/protocol.md): value, role, flags, reserved byte.
  kCount,
};

/// Stable lower-case name of a status ("ok", "too_short", "bad_crc", ...) for logs and telemetry columns.
const char* ToString(DecodeStatus status) noexcept;

/// Byte layout of a sample datagram (docs/protocol.md). All fields little-endian.
namespace wire {
inline constexpr std::uint32_t kMagic = 0x504F4C54;      ///< "TLOP" in byte order 54 4C 4F 50.
inline constexpr std::size_t kMagicOffset = 0;           // u32
inline constexpr std::size_t kVersionOffset = 4;         // u8
inline constexpr std::size_t kTypeOffset = 5;            // u8
inline constexpr std::size_t kSenderOffset = 6;          // u8
inline constexpr std::size_t kFlagsOffset = 7;           // u8
inline constexpr std::size_t kDofOffset = 8;             // u8
inline constexpr std::size_t kReservedOffset = 9;        // u8, sent as 0
inline constexpr std::size_t kPayloadLengthOffset = 10;  // u16, dof * kBytesPerDof [+ dof * kEnergyBytesPerDof]
inline constexpr std::size_t kSequenceOffset = 12;       // u32
inline constexpr std::size_t kSenderTimeOffset = 16;     // u64 ns
inline constexpr std::size_t kEchoTimeOffset = 24;       // u64 ns
inline constexpr std::size_t kEchoAgeOffset = 32;        // u32 ns
inline constexpr std::size_t kHeaderSize = 36;
inline constexpr std::size_t kBytesPerDof = 24;  ///< position f64, velocity f64, force f64.
inline constexpr std::size_t kCrcSize = 4;       ///< CRC-32C over every byte before it.
/// The optional energy block (time-domain passivity, docs/protocol.md "Energy block"): after the dof value blocks,
/// per DOF input energy f64 then output energy f64. Present exactly when payload_length = dof · (24 + 16).
inline constexpr std::size_t kEnergyBytesPerDof = 16;
}  // namespace wire

/// Largest encoded sample (bytes): header + 12 DOF × (3 + 2) doubles + CRC = 520 (328 without the energy block;
/// 6 DOF: 280 and 184).
inline constexpr std::size_t kMaxEncodedSampleBytes =
    wire::kHeaderSize + kMaxWireDof * (wire::kBytesPerDof + wire::kEnergyBytesPerDof) + wire::kCrcSize;
/// kMaxEncodedSampleBytes.
std::size_t MaxEncodedSampleSize() noexcept;
/// Encoded size for `dof` DOF (64 for 1 DOF; 80 with the energy block); 0 when dof is outside 1..kMaxWireDof.
std::size_t EncodedSampleSize(int dof, bool has_energy = false) noexcept;

/// Checks the fields a receiver checks after the CRC: role, flags, dof, finiteness and ranges of the first `dof`
/// values. Returns kOk, kBadDof, kOutOfRange or kNonFinite. A sender may call it to refuse to send garbage.
[[nodiscard]] DecodeStatus ValidateSample(const SampleMessage& message) noexcept;

/// Encodes explicitly little-endian into `out`; returns the bytes written, or 0 when `out` is too small or the
/// message is invalid (dof out of range). Values are not range-checked here (see ValidateSample): the receiver
/// rejects them. No allocation.
[[nodiscard]] std::size_t EncodeSample(const SampleMessage& message, std::span<std::uint8_t> out) noexcept;
/// Decodes and validates one datagram. `out` is written only on kOk. No allocation, never throws.
/// Checks in this order: size ≥ header, magic, version, type, dof, length field (dof · 24, or dof · 40 with the
/// energy block), size, CRC, then ValidateSample.
[[nodiscard]] DecodeStatus DecodeSample(std::span<const std::uint8_t> bytes, SampleMessage& out) noexcept;

}  // namespace teleop::proto
