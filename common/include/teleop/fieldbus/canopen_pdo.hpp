#pragma once

// Process data objects (CiA 301: PDO service, objects 0x1400-0x1BFF): a PDO's mapping (object, subindex, bit length per
// entry) and the packing of the mapped values into one classic CAN frame, little-endian, entry after entry. Only whole
// bytes of 8, 16 or 32 bits are mapped here. Pure: no I/O, no allocation, no exceptions.

#include <array>
#include <cstdint>
#include <span>

#include "teleop/fieldbus/canopen_frames.hpp"

namespace teleop::fieldbus::canopen {

inline constexpr int kMaxPdoEntries = 8;  ///< 8 entries of 8 bits fill a classic frame.
inline constexpr int kMaxPdoBytes = 8;

/// One mapped object: the 32-bit mapping entry of 0x1600+n / 0x1A00+n sub 1..8 is index << 16 | subindex << 8 |
/// bit length.
struct PdoEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::uint8_t bits = 0;  ///< 8, 16 or 32.

  constexpr std::uint32_t MappingValue() const noexcept {
    return std::uint32_t{index} << 16 | std::uint32_t{subindex} << 8 | bits;
  }
  static constexpr PdoEntry FromMappingValue(std::uint32_t value) noexcept {
    return PdoEntry{static_cast<std::uint16_t>(value >> 16), static_cast<std::uint8_t>(value >> 8),
                    static_cast<std::uint8_t>(value)};
  }
  friend constexpr bool operator==(const PdoEntry&, const PdoEntry&) = default;
};

/// One PDO: its number (1..4: RPDO n has communication object 0x1400 + n - 1 and mapping 0x1600 + n - 1, TPDO n
/// 0x1800 + n - 1 and 0x1A00 + n - 1), its COB-ID (0: the default of the predefined connection set), the
/// transmission type (1..240: synchronous, every n-th SYNC; 254/255 event-driven) and the mapped entries.
struct PdoMapping {
  int number = 1;
  std::uint32_t cob_id = 0;
  std::uint8_t transmission_type = 1;
  std::array<PdoEntry, kMaxPdoEntries> entries{};
  int entry_count = 0;

  std::span<const PdoEntry> mapped() const noexcept { return {entries.data(), static_cast<std::size_t>(entry_count)}; }
};

/// Why a mapping cannot be used.
enum class PdoMappingStatus : std::uint8_t {
  kOk,
  kBadNumber,        ///< number outside 1..4
  kBadCount,         ///< entry_count outside 1..8
  kBadEntryLength,   ///< an entry of other than 8, 16 or 32 bits
  kTooLong,          ///< more than 64 bits in all
  kBadCobId,         ///< a COB-ID outside 0x181..0x57F, or one that is not a PDO's (0x000, 0x080, SDO, heartbeat)
  kBadTransmission,  ///< transmission type 0 or 241..253
};
const char* ToString(PdoMappingStatus status) noexcept;
PdoMappingStatus CheckPdoMapping(const PdoMapping& mapping) noexcept;

/// Data bytes of the PDO (sum of the entries' bits / 8).
int PdoLength(const PdoMapping& mapping) noexcept;
/// The COB-ID the PDO uses: mapping.cob_id, or the default for node `node_id` (tpdo: drive → host).
std::uint32_t PdoCobId(const PdoMapping& mapping, bool tpdo, std::uint8_t node_id) noexcept;

/// Packs `values` (one per entry, raw; only the entry's low bits are sent) into `frame` on `cob_id`. False when
/// the counts differ.
[[nodiscard]] bool PackPdo(const PdoMapping& mapping, std::uint32_t cob_id, std::span<const std::uint32_t> values,
                           CanFrame& frame) noexcept;
/// Unpacks a received PDO into `values` (zero-extended). False when the frame's length is not the mapping's
/// (a drive with another mapping is refused, never misread) or the counts differ.
[[nodiscard]] bool UnpackPdo(const PdoMapping& mapping, const CanFrame& frame,
                             std::span<std::uint32_t> values) noexcept;

/// Sign-extends the low `bits` of `raw` (INTEGER8/16/32 objects).
constexpr std::int32_t SignExtend(std::uint32_t raw, int bits) noexcept {
  if (bits >= 32) return static_cast<std::int32_t>(raw);
  const std::uint32_t sign = 1u << (bits - 1);
  const std::uint32_t value = raw & ((1u << bits) - 1u);
  return static_cast<std::int32_t>(value ^ sign) - static_cast<std::int32_t>(sign);
}

}  // namespace teleop::fieldbus::canopen
