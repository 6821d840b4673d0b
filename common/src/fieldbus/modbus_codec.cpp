#include "teleop/fieldbus/modbus_codec.hpp"

#include <cmath>
#include <cstdint>

namespace teleop::fieldbus {

namespace {

bool IsBit(ModbusTable table) { return table == ModbusTable::kCoil || table == ModbusTable::kDiscreteInput; }

std::uint32_t Join(const ModbusPoint& p, const std::uint16_t* w) noexcept {
  const std::uint32_t first = w[0];
  const std::uint32_t second = w[1];
  return p.word_order == ModbusWordOrder::kHighWordFirst ? (first << 16) | second : (second << 16) | first;
}

void Split(const ModbusPoint& p, std::uint32_t raw, std::uint16_t* w) noexcept {
  const auto high = static_cast<std::uint16_t>(raw >> 16);
  const auto low = static_cast<std::uint16_t>(raw & 0xFFFFu);
  w[0] = p.word_order == ModbusWordOrder::kHighWordFirst ? high : low;
  w[1] = p.word_order == ModbusWordOrder::kHighWordFirst ? low : high;
}

struct Range {
  double low;
  double high;
};

Range RangeOf(ModbusValueType type) noexcept {
  switch (type) {
    case ModbusValueType::kUint16:
      return {0.0, 65535.0};
    case ModbusValueType::kInt16:
      return {-32768.0, 32767.0};
    case ModbusValueType::kUint32:
      return {0.0, 4294967295.0};
    case ModbusValueType::kInt32:
      return {-2147483648.0, 2147483647.0};
  }
  return {0.0, 0.0};
}

}  // namespace

double DecodePoint(const ModbusPoint& p, const std::uint16_t* words) noexcept {
  double raw = 0.0;
  if (IsBit(p.table)) {
    return words[0] != 0 ? 1.0 : 0.0;
  }
  switch (p.type) {
    case ModbusValueType::kUint16:
      raw = words[0];
      break;
    case ModbusValueType::kInt16:
      raw = static_cast<std::int16_t>(words[0]);
      break;
    case ModbusValueType::kUint32:
      raw = Join(p, words);
      break;
    case ModbusValueType::kInt32:
      raw = static_cast<std::int32_t>(Join(p, words));
      break;
  }
  return raw * p.scale + p.offset;
}

ModbusEncodeStatus EncodePoint(const ModbusPoint& p, double value_si, std::uint16_t* words) noexcept {
  ModbusEncodeStatus status = ModbusEncodeStatus::kOk;
  if (!std::isfinite(value_si)) {
    value_si = p.safe_value;
    status = ModbusEncodeStatus::kNonFinite;
  }
  if (IsBit(p.table)) {
    words[0] = value_si >= 0.5 ? 1 : 0;
    return status;
  }
  double raw = std::nearbyint((value_si - p.offset) / p.scale);
  const Range range = RangeOf(p.type);
  // A NaN here (an infinite safe_value cannot pass Validate) would fail both tests and stay: clamp it to low.
  if (!(raw >= range.low)) {
    raw = range.low;
    if (status == ModbusEncodeStatus::kOk) status = ModbusEncodeStatus::kClamped;
  } else if (raw > range.high) {
    raw = range.high;
    if (status == ModbusEncodeStatus::kOk) status = ModbusEncodeStatus::kClamped;
  }
  switch (p.type) {
    case ModbusValueType::kUint16:
      words[0] = static_cast<std::uint16_t>(raw);
      break;
    case ModbusValueType::kInt16:
      words[0] = static_cast<std::uint16_t>(static_cast<std::int16_t>(raw));
      break;
    case ModbusValueType::kUint32:
      Split(p, static_cast<std::uint32_t>(raw), words);
      break;
    case ModbusValueType::kInt32:
      Split(p, static_cast<std::uint32_t>(static_cast<std::int32_t>(raw)), words);
      break;
  }
  return status;
}

}  // namespace teleop::fieldbus
