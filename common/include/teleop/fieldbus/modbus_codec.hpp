#pragma once

// Register words <-> SI values of one ModbusPoint: type, word order, scale and offset. Pure functions, no I/O; the
// I/O thread uses them and so do the tests, with golden words.

#include <cstdint>

#include "teleop/fieldbus/modbus_config.hpp"

namespace teleop::fieldbus {

/// The SI value of `point` from its RegisterCount(point) words (a bit point: words[0] is 0 or 1).
double DecodePoint(const ModbusPoint& point, const std::uint16_t* words) noexcept;

enum class ModbusEncodeStatus : std::uint8_t {
  kOk,
  kClamped,    ///< The value was outside the raw type's range: the nearest end was encoded.
  kNonFinite,  ///< NaN/inf: the point's safe_value was encoded instead.
};

/// Writes the RegisterCount(point) words for `value_si` into `words` (a bit point: 1 when value_si >= 0.5).
[[nodiscard]] ModbusEncodeStatus EncodePoint(const ModbusPoint& point, double value_si, std::uint16_t* words) noexcept;

}  // namespace teleop::fieldbus
