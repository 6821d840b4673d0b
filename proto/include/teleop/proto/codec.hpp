#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "teleop/proto/sample_message.hpp"

namespace teleop::proto {

/// Result of decoding one datagram. Everything but kOk is a counted rejection.
enum class DecodeStatus : std::uint8_t {
  kOk = 0,
  kTooShort,        ///< Fewer bytes than the header, or than the header's dof needs.
  kBadMagic,        ///< Not a teleop datagram.
  kBadVersion,      ///< Another protocol version.
  kBadType,         ///< Unknown message type.
  kBadDof,          ///< dof of 0 or above kMaxWireDof.
  kBadLength,       ///< Length field disagrees with the datagram size.
  kBadCrc,          ///< CRC-32C mismatch.
  kNonFinite,       ///< NaN or infinity in a field.
  kOutOfRange,      ///< A field outside the documented range (docs/protocol.md).
  kCount,
};

const char* ToString(DecodeStatus status) noexcept;

/// Largest encoded sample (bytes): header + 6 DOF × 3 doubles + CRC.
std::size_t MaxEncodedSampleSize() noexcept;
/// Encoded size for `dof` DOF.
std::size_t EncodedSampleSize(int dof) noexcept;

/// Encodes explicitly little-endian into `out`; returns the bytes written, or 0 when `out` is too small or the
/// message is invalid (dof out of range). No allocation.
[[nodiscard]] std::size_t EncodeSample(const SampleMessage& message, std::span<std::uint8_t> out) noexcept;
/// Decodes and validates one datagram. `out` is written only on kOk. No allocation, never throws.
[[nodiscard]] DecodeStatus DecodeSample(std::span<const std::uint8_t> bytes, SampleMessage& out) noexcept;

}  // namespace teleop::proto
