#include "teleop/fieldbus/canopen_pdo.hpp"

namespace teleop::fieldbus::canopen {

const char* ToString(PdoMappingStatus status) noexcept {
  switch (status) {
    case PdoMappingStatus::kOk:
      return "ok";
    case PdoMappingStatus::kBadNumber:
      return "PDO number must be 1..4";
    case PdoMappingStatus::kBadCount:
      return "a PDO maps 1..8 objects";
    case PdoMappingStatus::kBadEntryLength:
      return "mapped objects must be 8, 16 or 32 bits";
    case PdoMappingStatus::kTooLong:
      return "mapped objects exceed 64 bits (8 bytes)";
    case PdoMappingStatus::kBadCobId:
      return "PDO COB-ID must be 0x181..0x57F (0: the default) and not an SDO/heartbeat/EMCY identifier";
    case PdoMappingStatus::kBadTransmission:
      return "transmission type must be 1..240 (synchronous) or 254/255 (event-driven)";
  }
  return "invalid";
}

PdoMappingStatus CheckPdoMapping(const PdoMapping& mapping) noexcept {
  if (mapping.number < 1 || mapping.number > 4) return PdoMappingStatus::kBadNumber;
  if (mapping.entry_count < 1 || mapping.entry_count > kMaxPdoEntries) return PdoMappingStatus::kBadCount;
  int bits = 0;
  for (const PdoEntry& e : mapping.mapped()) {
    if (e.bits != 8 && e.bits != 16 && e.bits != 32) return PdoMappingStatus::kBadEntryLength;
    bits += e.bits;
  }
  if (bits > 8 * kMaxPdoBytes) return PdoMappingStatus::kTooLong;
  const std::uint32_t id = mapping.cob_id & ~(cob::kInvalidBit | cob::kNoRtrBit);
  if (mapping.cob_id != 0 && (id < 0x181 || id > 0x57F || (id & cob::kFrameBit) != 0)) {
    return PdoMappingStatus::kBadCobId;
  }
  const std::uint8_t t = mapping.transmission_type;
  if (t == 0 || (t > 240 && t < 254)) return PdoMappingStatus::kBadTransmission;
  return PdoMappingStatus::kOk;
}

int PdoLength(const PdoMapping& mapping) noexcept {
  int bits = 0;
  for (const PdoEntry& e : mapping.mapped()) bits += e.bits;
  return bits / 8;
}

std::uint32_t PdoCobId(const PdoMapping& mapping, bool tpdo, std::uint8_t node_id) noexcept {
  if (mapping.cob_id != 0) return mapping.cob_id & 0x7FFu;
  return tpdo ? cob::DefaultTpdo(mapping.number, node_id) : cob::DefaultRpdo(mapping.number, node_id);
}

bool PackPdo(const PdoMapping& mapping, std::uint32_t cob_id, std::span<const std::uint32_t> values,
             CanFrame& frame) noexcept {
  if (values.size() != static_cast<std::size_t>(mapping.entry_count) || PdoLength(mapping) > kMaxPdoBytes) {
    return false;
  }
  frame = CanFrame{};
  frame.id = cob_id & 0x7FFu;
  std::size_t at = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const int bytes = mapping.entries[i].bits / 8;
    for (int b = 0; b < bytes; ++b) frame.data[at++] = static_cast<std::uint8_t>(values[i] >> (8 * b));
  }
  frame.len = static_cast<std::uint8_t>(at);
  return true;
}

bool UnpackPdo(const PdoMapping& mapping, const CanFrame& frame, std::span<std::uint32_t> values) noexcept {
  if (values.size() != static_cast<std::size_t>(mapping.entry_count)) return false;
  if (frame.error || frame.fd || frame.remote || frame.len != PdoLength(mapping)) return false;
  std::size_t at = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const int bytes = mapping.entries[i].bits / 8;
    std::uint32_t v = 0;
    for (int b = 0; b < bytes; ++b) v |= std::uint32_t{frame.data[at++]} << (8 * b);
    values[i] = v;
  }
  return true;
}

}  // namespace teleop::fieldbus::canopen
