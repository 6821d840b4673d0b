// Modbus RTU without hardware: a pty pair from socat, the pymodbus server on one end (RTU framer, CRC-16), the I/O
// thread on the other at 19200 baud 8N1. Same register map and fault handling as TCP, over the serial code path.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <thread>

#include "modbus_test_server.hpp"
#include "teleop/fieldbus/modbus_io_thread.hpp"

namespace teleop::fieldbus {
namespace {

bool WaitFor(const std::function<bool()>& done, double timeout_s = 20.0) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return done();
}

ModbusConfig RtuConfig(const std::string& device) {
  ModbusConfig c;
  c.transport = ModbusTransport::kRtu;
  c.rtu.device = device;
  c.rtu.baud = 19200;
  c.rtu.parity = 'N';  // a pty refuses parity (tcsetattr: EINVAL); a real line would use 8E1
  c.unit_id = 7;
  c.poll_period_ms = 20.0;
  c.response_timeout_ms = 200.0;
  c.stale_after_ms = 3000.0;
  c.command_timeout_ms = 0.0;
  ModbusPoint force;
  force.name = "force_N";
  force.table = ModbusTable::kInputRegister;
  force.address = 4;
  force.type = ModbusValueType::kInt16;
  force.scale = 0.01;
  c.inputs.push_back(force);
  ModbusPoint torque;
  torque.name = "torque_Nm";
  torque.table = ModbusTable::kHoldingRegister;
  torque.address = 10;
  torque.type = ModbusValueType::kInt32;
  torque.scale = 0.001;
  c.outputs.push_back(torque);
  return c;
}

ModbusReading ThreadView(ModbusIoThread& io) {
  ModbusReading r;
  (void)io.LatestReading(r, -std::numeric_limits<double>::infinity());
  return r;
}

TEST(ModbusRtu, ExchangesOverAPtyPairAndFaultsWhenTheDeviceGoesQuietOrAnswersExceptions) {
  test::PtyPair pty;
  test::ModbusTestServer server = test::ModbusTestServer::Rtu(pty.server_end(), 7);
  ASSERT_EQ(server.Control("set ir 4 65436"), "ok");  // -100 -> -1.00 N
  ModbusIoThread io(RtuConfig(pty.client_end()));
  io.Start();
  ASSERT_TRUE(io.WaitForFirstPoll(20.0)) << "no RTU answer; counters: timeouts " << io.counters().timeouts
                                         << ", protocol errors " << io.counters().protocol_errors;
  ModbusReading r;
  ASSERT_TRUE(WaitFor([&] { return io.LatestReading(r) == device::kFaultNone; }));
  EXPECT_NEAR(r.values[0], -1.0, 1e-12);
  ModbusCommand command;
  command.values[0] = 2.5;  // 2500 = 0x000009C4
  io.PublishCommand(command);
  EXPECT_TRUE(WaitFor([&] { return server.Control("get hr 10 2") == "0 2500"; })) << server.Control("get hr 10 2");

  // The device goes quiet: a counted timeout and the thread's own fault; then it answers again.
  ASSERT_EQ(server.Control("mode stop"), "ok");
  EXPECT_TRUE(WaitFor([&] { return (ThreadView(io).faults & device::kFaultCommunication) != 0; }));
  EXPECT_GE(io.counters().timeouts, 1u);
  ASSERT_EQ(server.Control("mode normal"), "ok");
  std::uint64_t seq = ThreadView(io).sequence;
  EXPECT_TRUE(WaitFor([&] { return io.LatestReading(r) == device::kFaultNone && r.sequence > seq; }));

  // Exception responses over RTU.
  ASSERT_EQ(server.Control("mode exception 4"), "ok");
  EXPECT_TRUE(WaitFor([&] { return (ThreadView(io).faults & device::kFaultCommunication) != 0; }));
  EXPECT_GE(io.counters().exceptions, 1u);
  EXPECT_EQ(io.counters().last_exception_code, 4u);
  ASSERT_EQ(server.Control("mode normal"), "ok");
  seq = ThreadView(io).sequence;
  EXPECT_TRUE(WaitFor([&] { return io.LatestReading(r) == device::kFaultNone && r.sequence > seq; }));
  EXPECT_EQ(io.counters().disconnects, 0u);
}

}  // namespace
}  // namespace teleop::fieldbus
