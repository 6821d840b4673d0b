#pragma once

#include <cstdint>
#include <span>

namespace teleop::proto {

/// CRC-32C (Castagnoli: polynomial 0x1EDC6F41, reflected, init and final XOR 0xFFFFFFFF), as in iSCSI/SCTP.
/// Check value: Crc32c("123456789") == 0xE3069283. Computed with Boost.CRC; no allocation.
std::uint32_t Crc32c(std::span<const std::uint8_t> bytes) noexcept;

}  // namespace teleop::proto
