// The Modbus config section reader: a full section, defaults, and errors located at FILE:LINE:COL with the key path.

#include "teleop/fieldbus/modbus_yaml.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <string>

#include "teleop/error.hpp"

namespace teleop::fieldbus {
namespace {

using ::testing::HasSubstr;

constexpr const char* kFull = R"(transport: tcp
tcp: {host: 192.168.1.20, port: 1502}
unit_id: 3
poll_period_ms: 5
response_timeout_ms: 20
byte_timeout_ms: 2
connect_timeout_ms: 300
reconnect_initial_ms: 10
reconnect_max_ms: 500
stale_after_ms: 50
command_timeout_ms: 40
inputs:
  - {name: force_N, table: input_register, address: 0, type: int16, scale: 0.01, offset: -1.5}
  - {name: position_m, table: input_register, address: 1, type: int32, word_order: low_word_first, scale: 1.0e-6}
  - {name: brake_ok, table: discrete_input, address: 7}
outputs:
  - {name: brake_torque_Nm, table: holding_register, address: 100, type: uint32, scale: 0.001, safe_value: 0.2}
  - {name: enable, table: coil, address: 2}
)";

std::string ErrorOf(const std::string& yaml) {
  try {
    (void)ParseModbusConfig(yaml, "amp.yaml");
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(ModbusYaml, ReadsAFullSection) {
  const ModbusConfig c = ParseModbusConfig(kFull, "amp.yaml");
  EXPECT_EQ(c.transport, ModbusTransport::kTcp);
  EXPECT_EQ(c.tcp.host, "192.168.1.20");
  EXPECT_EQ(c.tcp.port, 1502);
  EXPECT_EQ(c.unit_id, 3);
  EXPECT_EQ(c.poll_period_ms, 5.0);
  EXPECT_EQ(c.response_timeout_ms, 20.0);
  EXPECT_EQ(c.byte_timeout_ms, 2.0);
  EXPECT_EQ(c.connect_timeout_ms, 300.0);
  EXPECT_EQ(c.reconnect_initial_ms, 10.0);
  EXPECT_EQ(c.reconnect_max_ms, 500.0);
  EXPECT_EQ(c.stale_after_ms, 50.0);
  EXPECT_EQ(c.command_timeout_ms, 40.0);
  ASSERT_EQ(c.inputs.size(), 3u);
  EXPECT_EQ(c.inputs[0].name, "force_N");
  EXPECT_EQ(c.inputs[0].table, ModbusTable::kInputRegister);
  EXPECT_EQ(c.inputs[0].type, ModbusValueType::kInt16);
  EXPECT_EQ(c.inputs[0].scale, 0.01);
  EXPECT_EQ(c.inputs[0].offset, -1.5);
  EXPECT_EQ(c.inputs[1].word_order, ModbusWordOrder::kLowWordFirst);
  EXPECT_EQ(c.inputs[1].type, ModbusValueType::kInt32);
  EXPECT_EQ(c.inputs[2].table, ModbusTable::kDiscreteInput);
  ASSERT_EQ(c.outputs.size(), 2u);
  EXPECT_EQ(c.outputs[0].type, ModbusValueType::kUint32);
  EXPECT_EQ(c.outputs[0].word_order, ModbusWordOrder::kHighWordFirst);
  EXPECT_EQ(c.outputs[0].safe_value, 0.2);
  EXPECT_EQ(c.outputs[1].table, ModbusTable::kCoil);
}

TEST(ModbusYaml, PointsAreFoundByName) {
  const ModbusConfig c = ParseModbusConfig(kFull, "amp.yaml");
  EXPECT_EQ(FindPoint(c.inputs, "position_m"), 1);
  EXPECT_EQ(FindPoint(c.outputs, "enable"), 1);
  EXPECT_EQ(FindPoint(c.outputs, "force_N"), -1);
}

TEST(ModbusYaml, RtuWithDefaults) {
  const ModbusConfig c = ParseModbusConfig(R"(transport: rtu
rtu: {device: /dev/ttyUSB0, parity: none, stop_bits: 2}
inputs: [{name: f, table: holding_register, address: 0}]
)",
                                           "amp.yaml");
  EXPECT_EQ(c.transport, ModbusTransport::kRtu);
  EXPECT_EQ(c.rtu.device, "/dev/ttyUSB0");
  EXPECT_EQ(c.rtu.baud, 19200);
  EXPECT_EQ(c.rtu.parity, 'N');
  EXPECT_EQ(c.rtu.stop_bits, 2);
  EXPECT_EQ(c.unit_id, 1);
  EXPECT_EQ(c.poll_period_ms, 10.0);
  EXPECT_EQ(c.stale_after_ms, 100.0);
}

TEST(ModbusYaml, ErrorsNameTheFileLineColumnAndKey) {
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\npoll_perod_ms: 5\n"),
              HasSubstr("amp.yaml:3:1: key 'poll_perod_ms': unknown key (did you mean 'poll_period_ms'?)"));
  EXPECT_THAT(ErrorOf("transport: can\n"), HasSubstr("amp.yaml:1:12: key 'transport': must be one of tcp, rtu"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a, port: 70000}\n"),
              HasSubstr("amp.yaml:2:22: key 'tcp.port': must be an integer in 1..65535, got 70000"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\nstale_after_ms: 20\ninputs: [{name: f, table: coil, "
                      "address: 0}]\n"),
              HasSubstr("key 'stale_after_ms': must exceed poll_period_ms + response_timeout_ms (60 ms)"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\noutputs: [{name: f, table: input_register, address: 0}]\n"),
              HasSubstr("key 'outputs[0].table': must be one of holding_register, coil, got 'input_register'"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\ninputs: [{name: f, table: coil, address: 0, type: int16}]\n"),
              HasSubstr("key 'inputs[0].type': a coil or discrete input is one bit"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\ninputs: [{name: f, table: input_register, address: 0, "
                      "word_order: low_word_first}]\n"),
              HasSubstr("word_order applies to 32-bit types"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\ninputs: [{name: f, table: input_register, address: 65535, "
                      "type: int32}]\n"),
              HasSubstr("key 'inputs[0].address': a 32-bit value needs two registers"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\ninputs: [{name: f, table: input_register, address: 0, "
                      "scale: 0}]\n"),
              HasSubstr("key 'inputs[0].scale': must not be 0"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\n"), HasSubstr("the register map is empty"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\noutputs:\n  - {name: a, table: holding_register, address: 0, "
                      "type: int32}\n  - {name: b, table: holding_register, address: 1}\n"),
              HasSubstr("outputs 'a' and 'b' overlap"));
  EXPECT_THAT(ErrorOf("transport: rtu\nrtu: {device: /dev/x}\nunit_id: 0\ninputs: [{name: f, table: coil, address: "
                      "0}]\n"),
              HasSubstr("key 'unit_id': must be an integer in 1..247"));
  EXPECT_THAT(ErrorOf("transport: tcp\nrtu: {device: /dev/x}\n"), HasSubstr("transport is tcp: remove the rtu"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\npoll_period_ms: .nan\n"),
              HasSubstr("key 'poll_period_ms': must be a finite number"));
  EXPECT_THAT(ErrorOf("transport: [tcp\n"), HasSubstr("amp.yaml:"));
  EXPECT_THAT(ErrorOf("transport: tcp\ntcp: {host: a}\ninputs: [{name: f, table: coil, address: 0}, {name: f, table: "
                      "coil, address: 1}]\n"),
              HasSubstr("two inputs are called 'f'"));
}

TEST(ModbusYaml, ReadsANestedSectionWithItsPath) {
  const YAML::Node root = YAML::Load("device:\n  amp:\n    transport: tcp\n    tcp: {host: a}\n    unit_id: 300\n");
  try {
    (void)ReadModbusConfig(root["device"]["amp"], "device.amp", "rig.yaml");
    FAIL() << "unit_id 300 accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("rig.yaml:5:14: key 'device.amp.unit_id': must be an integer in 0..255"));
  }
}

}  // namespace
}  // namespace teleop::fieldbus
