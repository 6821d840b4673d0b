#include "teleop/fieldbus/modbus_config.hpp"

#include <cmath>
#include <sstream>
#include <string>

#include "teleop/error.hpp"

namespace teleop::fieldbus {

namespace {

std::string Num(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

void Require(bool ok, const std::string& what) {
  if (!ok) throw Error("modbus config: " + what);
}

bool Finite(double v) { return std::isfinite(v); }

bool IsBit(ModbusTable table) { return table == ModbusTable::kCoil || table == ModbusTable::kDiscreteInput; }

void ValidatePoint(const ModbusPoint& p, const std::string& where, bool output) {
  const std::string name = where + " '" + p.name + "'";
  Require(!p.name.empty(), where + ": a point needs a name");
  Require(p.address >= 0 && p.address + RegisterCount(p) - 1 <= 65535, name + ": address " + std::to_string(p.address) +
                                                                           " (+" + std::to_string(RegisterCount(p)) +
                                                                           " registers) is outside 0..65535");
  Require(Finite(p.scale) && p.scale != 0.0, name + ": scale must be finite and non-zero, got " + Num(p.scale));
  Require(Finite(p.offset), name + ": offset must be finite, got " + Num(p.offset));
  Require(Finite(p.safe_value), name + ": safe_value must be finite, got " + Num(p.safe_value));
  if (output) {
    Require(p.table == ModbusTable::kCoil || p.table == ModbusTable::kHoldingRegister,
            name + ": an output must be a coil or a holding register, got " + ToString(p.table) + " (read-only table)");
  }
}

}  // namespace

int RegisterCount(const ModbusPoint& point) noexcept {
  if (IsBit(point.table)) return 1;
  return (point.type == ModbusValueType::kUint32 || point.type == ModbusValueType::kInt32) ? 2 : 1;
}

const char* ToString(ModbusTable table) noexcept {
  switch (table) {
    case ModbusTable::kCoil:
      return "coil";
    case ModbusTable::kDiscreteInput:
      return "discrete_input";
    case ModbusTable::kInputRegister:
      return "input_register";
    case ModbusTable::kHoldingRegister:
      return "holding_register";
  }
  return "?";
}

const char* ToString(ModbusValueType type) noexcept {
  switch (type) {
    case ModbusValueType::kUint16:
      return "uint16";
    case ModbusValueType::kInt16:
      return "int16";
    case ModbusValueType::kUint32:
      return "uint32";
    case ModbusValueType::kInt32:
      return "int32";
  }
  return "?";
}

const char* ToString(ModbusWordOrder order) noexcept {
  switch (order) {
    case ModbusWordOrder::kHighWordFirst:
      return "high_word_first";
    case ModbusWordOrder::kLowWordFirst:
      return "low_word_first";
  }
  return "?";
}

int FindPoint(const std::vector<ModbusPoint>& points, std::string_view name) noexcept {
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (points[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

void Validate(const ModbusConfig& c) {
  if (c.transport == ModbusTransport::kTcp) {
    Require(!c.tcp.host.empty(), "tcp.host is empty");
    Require(c.tcp.port >= 1 && c.tcp.port <= 65535, "tcp.port must be in 1..65535, got " + std::to_string(c.tcp.port));
  }
  if (c.transport == ModbusTransport::kRtu) {
    Require(!c.rtu.device.empty(), "rtu.device is empty (a serial device such as /dev/ttyUSB0)");
    Require(c.rtu.baud >= 300 && c.rtu.baud <= 4'000'000,
            "rtu.baud must be in 300..4000000, got " + std::to_string(c.rtu.baud));
    Require(c.rtu.parity == 'N' || c.rtu.parity == 'E' || c.rtu.parity == 'O', "rtu.parity must be N, E or O");
    Require(c.rtu.data_bits >= 5 && c.rtu.data_bits <= 8, "rtu.data_bits must be in 5..8");
    Require(c.rtu.stop_bits == 1 || c.rtu.stop_bits == 2, "rtu.stop_bits must be 1 or 2");
    Require(
        c.unit_id >= 1 && c.unit_id <= 247,
        "unit_id must be in 1..247 on RTU (0 is broadcast, which is never answered), got " + std::to_string(c.unit_id));
  } else {
    Require(c.unit_id >= 0 && c.unit_id <= 255, "unit_id must be in 0..255, got " + std::to_string(c.unit_id));
  }
  const auto positive = [](double v) { return Finite(v) && v > 0.0; };
  Require(positive(c.poll_period_ms), "poll_period_ms must be > 0, got " + Num(c.poll_period_ms));
  Require(Finite(c.response_timeout_ms) && c.response_timeout_ms >= 1.0,
          "response_timeout_ms must be >= 1, got " + Num(c.response_timeout_ms));
  Require(Finite(c.byte_timeout_ms) && c.byte_timeout_ms >= 0.0,
          "byte_timeout_ms must be >= 0, got " + Num(c.byte_timeout_ms));
  Require(Finite(c.connect_timeout_ms) && c.connect_timeout_ms >= 1.0,
          "connect_timeout_ms must be >= 1, got " + Num(c.connect_timeout_ms));
  Require(positive(c.reconnect_initial_ms), "reconnect_initial_ms must be > 0, got " + Num(c.reconnect_initial_ms));
  Require(Finite(c.reconnect_max_ms) && c.reconnect_max_ms >= c.reconnect_initial_ms,
          "reconnect_max_ms must be >= reconnect_initial_ms, got " + Num(c.reconnect_max_ms));
  Require(Finite(c.stale_after_ms) && c.stale_after_ms > c.poll_period_ms + c.response_timeout_ms,
          "stale_after_ms (" + Num(c.stale_after_ms) + ") must exceed poll_period_ms + response_timeout_ms (" +
              Num(c.poll_period_ms + c.response_timeout_ms) + "), or a healthy bus would read as stale");
  Require(Finite(c.command_timeout_ms) && c.command_timeout_ms >= 0.0,
          "command_timeout_ms must be >= 0 (0 = off), got " + Num(c.command_timeout_ms));
  Require(!c.inputs.empty() || !c.outputs.empty(), "the register map is empty: give inputs, outputs or both");
  Require(static_cast<int>(c.inputs.size()) <= kMaxModbusPoints,
          "at most " + std::to_string(kMaxModbusPoints) + " inputs, got " + std::to_string(c.inputs.size()));
  Require(static_cast<int>(c.outputs.size()) <= kMaxModbusPoints,
          "at most " + std::to_string(kMaxModbusPoints) + " outputs, got " + std::to_string(c.outputs.size()));
  for (std::size_t i = 0; i < c.inputs.size(); ++i) {
    ValidatePoint(c.inputs[i], "input", false);
    Require(FindPoint(c.inputs, c.inputs[i].name) == static_cast<int>(i),
            "two inputs are called '" + c.inputs[i].name + "' (names must be unique)");
  }
  for (std::size_t i = 0; i < c.outputs.size(); ++i) {
    const ModbusPoint& a = c.outputs[i];
    ValidatePoint(a, "output", true);
    Require(FindPoint(c.outputs, a.name) == static_cast<int>(i),
            "two outputs are called '" + a.name + "' (names must be unique)");
    for (std::size_t j = 0; j < i; ++j) {
      const ModbusPoint& b = c.outputs[j];
      const bool overlap =
          a.table == b.table && a.address < b.address + RegisterCount(b) && b.address < a.address + RegisterCount(a);
      Require(!overlap, "outputs '" + b.name + "' and '" + a.name + "' overlap in the " + ToString(a.table) +
                            " table (they would overwrite each other)");
    }
  }
}

}  // namespace teleop::fieldbus
