#include "teleop/fieldbus/modbus_yaml.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <initializer_list>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>

#include "config/yaml_reader.hpp"  // the config library's Field/Map helpers (file:line:col errors)
#include "teleop/error.hpp"

namespace teleop::fieldbus {

namespace {

using config::detail::Field;
using config::detail::Map;

std::string Num(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

double Finite(const Field& f) {
  const double v = f.AsDouble();
  if (!std::isfinite(v)) f.Fail("must be a finite number, got " + Num(v));
  return v;
}

double Positive(const Field& f, const char* unit) {
  const double v = Finite(f);
  if (!(v > 0.0)) f.Fail("must be > 0 " + std::string(unit) + ", got " + Num(v));
  return v;
}

double NonNegative(const Field& f, const char* unit) {
  const double v = Finite(f);
  if (v < 0.0) f.Fail("must be >= 0 " + std::string(unit) + ", got " + Num(v));
  return v;
}

double AtLeast(const Field& f, double low, const char* unit) {
  const double v = Finite(f);
  if (v < low) f.Fail("must be >= " + Num(low) + " " + std::string(unit) + ", got " + Num(v));
  return v;
}

int IntInRange(const Field& f, int low, int high) {
  const int v = f.AsInt();
  if (v < low || v > high) {
    f.Fail("must be an integer in " + std::to_string(low) + ".." + std::to_string(high) + ", got " + std::to_string(v));
  }
  return v;
}

/// One of `names` (the YAML spellings), returned as the matching entry of `values`.
template <typename E>
E OneOf(const Field& f, std::initializer_list<std::pair<std::string_view, E>> choices) {
  const std::string text = f.AsString();
  std::string list;
  for (const auto& [name, value] : choices) {
    if (text == name) return value;
    list += (list.empty() ? "" : ", ") + std::string(name);
  }
  f.Fail("must be one of " + list + ", got '" + text + "'");
}

ModbusPoint ReadPoint(const Field& f, bool output) {
  const Map map = output ? Map(f, {"name", "table", "address", "type", "word_order", "scale", "offset", "safe_value"})
                         : Map(f, {"name", "table", "address", "type", "word_order", "scale", "offset"});
  ModbusPoint p;
  p.name = map.Required("name").AsString();
  if (p.name.empty()) map.Required("name").Fail("must not be empty");
  const Field table = map.Required("table");
  p.table = output ? OneOf<ModbusTable>(
                         table, {{"holding_register", ModbusTable::kHoldingRegister}, {"coil", ModbusTable::kCoil}})
                   : OneOf<ModbusTable>(table, {{"holding_register", ModbusTable::kHoldingRegister},
                                                {"input_register", ModbusTable::kInputRegister},
                                                {"coil", ModbusTable::kCoil},
                                                {"discrete_input", ModbusTable::kDiscreteInput}});
  p.address = IntInRange(map.Required("address"), 0, 65535);
  const bool bit = p.table == ModbusTable::kCoil || p.table == ModbusTable::kDiscreteInput;
  if (auto v = map.Optional("type")) {
    if (bit) v->Fail("a coil or discrete input is one bit: it takes no type");
    p.type = OneOf<ModbusValueType>(*v, {{"int16", ModbusValueType::kInt16},
                                         {"uint16", ModbusValueType::kUint16},
                                         {"int32", ModbusValueType::kInt32},
                                         {"uint32", ModbusValueType::kUint32}});
  }
  if (auto v = map.Optional("word_order")) {
    if (RegisterCount(p) != 2) v->Fail("word_order applies to 32-bit types (int32, uint32) only");
    p.word_order = OneOf<ModbusWordOrder>(
        *v, {{"high_word_first", ModbusWordOrder::kHighWordFirst}, {"low_word_first", ModbusWordOrder::kLowWordFirst}});
  }
  if (p.address + RegisterCount(p) - 1 > 65535) {
    map.Required("address").Fail("a 32-bit value needs two registers: the last address is 65534");
  }
  if (auto v = map.Optional("scale")) {
    if (bit) v->Fail("a bit reads as 0 or 1: it takes no scale");
    p.scale = Finite(*v);
    if (p.scale == 0.0) v->Fail("must not be 0 (SI units per raw count)");
  }
  if (auto v = map.Optional("offset")) {
    if (bit) v->Fail("a bit reads as 0 or 1: it takes no offset");
    p.offset = Finite(*v);
  }
  if (output) {
    if (auto v = map.Optional("safe_value")) p.safe_value = Finite(*v);
  }
  return p;
}

std::vector<ModbusPoint> ReadPoints(const Field& f, bool output) {
  const std::vector<Field> items = f.AsList();
  if (static_cast<int>(items.size()) > kMaxModbusPoints) {
    f.Fail("at most " + std::to_string(kMaxModbusPoints) + " points, got " + std::to_string(items.size()));
  }
  std::vector<ModbusPoint> out;
  out.reserve(items.size());
  for (const Field& item : items) out.push_back(ReadPoint(item, output));
  return out;
}

ModbusConfig Read(const Field& section) {
  const Map map(section, {"transport", "tcp", "rtu", "unit_id", "poll_period_ms", "response_timeout_ms",
                          "byte_timeout_ms", "connect_timeout_ms", "reconnect_initial_ms", "reconnect_max_ms",
                          "stale_after_ms", "command_timeout_ms", "inputs", "outputs"});
  ModbusConfig c;
  c.transport = OneOf<ModbusTransport>(map.Required("transport"),
                                       {{"tcp", ModbusTransport::kTcp}, {"rtu", ModbusTransport::kRtu}});
  if (c.transport == ModbusTransport::kTcp) {
    if (auto v = map.Optional("rtu")) v->Fail("transport is tcp: remove the rtu section (or set transport: rtu)");
    const Map tcp(map.Required("tcp"), {"host", "port"});
    c.tcp.host = tcp.Required("host").AsString();
    if (c.tcp.host.empty()) tcp.Required("host").Fail("must not be empty");
    if (auto v = tcp.Optional("port")) c.tcp.port = IntInRange(*v, 1, 65535);
  } else {
    if (auto v = map.Optional("tcp")) v->Fail("transport is rtu: remove the tcp section (or set transport: tcp)");
    const Map rtu(map.Required("rtu"), {"device", "baud", "parity", "data_bits", "stop_bits"});
    c.rtu.device = rtu.Required("device").AsString();
    if (c.rtu.device.empty()) rtu.Required("device").Fail("must not be empty");
    if (auto v = rtu.Optional("baud")) c.rtu.baud = IntInRange(*v, 300, 4'000'000);
    if (auto v = rtu.Optional("parity")) c.rtu.parity = OneOf<char>(*v, {{"none", 'N'}, {"even", 'E'}, {"odd", 'O'}});
    if (auto v = rtu.Optional("data_bits")) c.rtu.data_bits = IntInRange(*v, 5, 8);
    if (auto v = rtu.Optional("stop_bits")) c.rtu.stop_bits = IntInRange(*v, 1, 2);
  }
  if (auto v = map.Optional("unit_id")) {
    c.unit_id = c.transport == ModbusTransport::kRtu ? IntInRange(*v, 1, 247) : IntInRange(*v, 0, 255);
  }
  if (auto v = map.Optional("poll_period_ms")) c.poll_period_ms = Positive(*v, "ms");
  if (auto v = map.Optional("response_timeout_ms")) c.response_timeout_ms = AtLeast(*v, 1.0, "ms");
  if (auto v = map.Optional("byte_timeout_ms")) c.byte_timeout_ms = NonNegative(*v, "ms (0 = off)");
  if (auto v = map.Optional("connect_timeout_ms")) c.connect_timeout_ms = AtLeast(*v, 1.0, "ms");
  if (auto v = map.Optional("reconnect_initial_ms")) c.reconnect_initial_ms = Positive(*v, "ms");
  if (auto v = map.Optional("reconnect_max_ms")) {
    c.reconnect_max_ms = Positive(*v, "ms");
    if (c.reconnect_max_ms < c.reconnect_initial_ms) {
      v->Fail("must be >= reconnect_initial_ms (" + Num(c.reconnect_initial_ms) + " ms)");
    }
  } else {
    c.reconnect_max_ms = std::max(c.reconnect_max_ms, c.reconnect_initial_ms);
  }
  if (auto v = map.Optional("stale_after_ms")) {
    c.stale_after_ms = Positive(*v, "ms");
    if (!(c.stale_after_ms > c.poll_period_ms + c.response_timeout_ms)) {
      v->Fail("must exceed poll_period_ms + response_timeout_ms (" + Num(c.poll_period_ms + c.response_timeout_ms) +
              " ms), or a healthy bus would read as stale");
    }
  }
  if (auto v = map.Optional("command_timeout_ms")) c.command_timeout_ms = NonNegative(*v, "ms (0 = off)");
  if (auto v = map.Optional("inputs")) c.inputs = ReadPoints(*v, false);
  if (auto v = map.Optional("outputs")) c.outputs = ReadPoints(*v, true);
  try {
    Validate(c);  // the cross-field rules (timing relations, overlapping outputs, an empty map)
  } catch (const Error& e) {
    section.Fail(e.what());
  }
  return c;
}

}  // namespace

ModbusConfig ReadModbusConfig(const YAML::Node& node, const std::string& path, const std::string& file) {
  try {
    return Read(Field(node, path, &file));
  } catch (const YAML::Exception& e) {
    throw Error(config::detail::Located(file, e.mark, path, "cannot read the modbus section: " + e.msg));
  }
}

ModbusConfig ParseModbusConfig(const std::string& yaml_text, const std::string& name) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw Error(config::detail::Located(name, e.mark, "", "YAML syntax error: " + e.msg));
  }
  return ReadModbusConfig(root, "", name);
}

}  // namespace teleop::fieldbus
