#pragma once

// Explicit little-endian access for the codecs (codec.cpp, secure_codec.cpp): shifts on integers, std::bit_cast for
// doubles. Independent of host byte order and alignment; received bytes are never reinterpreted in place. Private to
// the proto library.

#include <bit>
#include <cstdint>

namespace teleop::proto::little_endian {

inline void PutU8(std::uint8_t* p, std::uint8_t v) noexcept { p[0] = v; }
inline void PutU16(std::uint8_t* p, std::uint16_t v) noexcept {
  for (int i = 0; i < 2; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
inline void PutU32(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
inline void PutU64(std::uint8_t* p, std::uint64_t v) noexcept {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}
inline void PutF64(std::uint8_t* p, double v) noexcept { PutU64(p, std::bit_cast<std::uint64_t>(v)); }

inline std::uint16_t GetU16(const std::uint8_t* p) noexcept { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
inline std::uint32_t GetU32(const std::uint8_t* p) noexcept {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
inline std::uint64_t GetU64(const std::uint8_t* p) noexcept {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
inline double GetF64(const std::uint8_t* p) noexcept { return std::bit_cast<double>(GetU64(p)); }

}  // namespace teleop::proto::little_endian
