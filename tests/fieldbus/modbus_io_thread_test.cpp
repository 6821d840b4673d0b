// The Modbus I/O thread against the pymodbus test server over TCP (tests/fieldbus/modbus_server.py): register map
// and scaling both ways, safe outputs, and every fault the server can inject. No test measures speed: waits are
// generous upper bounds, the assertions are on counters and on the fault/stale state.

#include "teleop/fieldbus/modbus_io_thread.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <thread>

#include "modbus_test_server.hpp"
#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::fieldbus {
namespace {

using test::ModbusTestServer;

constexpr double kWaitS = 20.0;  // upper bound of every wait (a loaded CI machine); a pass takes far less

bool WaitFor(const std::function<bool()>& done, double timeout_s = kWaitS) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return done();
}

ModbusPoint Point(const char* name, ModbusTable table, int address, ModbusValueType type, double scale = 1.0,
                  double offset = 0.0) {
  ModbusPoint p;
  p.name = name;
  p.table = table;
  p.address = address;
  p.type = type;
  p.scale = scale;
  p.offset = offset;
  return p;
}

/// A brake-amplifier-like map: a force sensor, an encoder, a switch and a set-point in; torque, enable, gain out.
ModbusConfig TcpConfig(int port) {
  ModbusConfig c;
  c.transport = ModbusTransport::kTcp;
  c.tcp.port = port;
  c.poll_period_ms = 10.0;
  c.response_timeout_ms = 300.0;  // generous: a loaded machine must not time out a healthy server
  c.connect_timeout_ms = 500.0;
  c.reconnect_initial_ms = 50.0;
  c.reconnect_max_ms = 200.0;
  c.stale_after_ms = 2000.0;  // generous: a loaded machine must not make a healthy bus read as stale
  c.command_timeout_ms = 0.0;
  c.inputs.push_back(Point("force_N", ModbusTable::kInputRegister, 0, ModbusValueType::kInt16, 0.01));
  ModbusPoint position = Point("position_m", ModbusTable::kInputRegister, 1, ModbusValueType::kInt32, 1e-6);
  position.word_order = ModbusWordOrder::kLowWordFirst;
  c.inputs.push_back(position);
  c.inputs.push_back(Point("switch", ModbusTable::kDiscreteInput, 3, ModbusValueType::kUint16));
  c.inputs.push_back(Point("setpoint", ModbusTable::kHoldingRegister, 20, ModbusValueType::kUint16, 0.5, -10.0));
  c.outputs.push_back(Point("torque_Nm", ModbusTable::kHoldingRegister, 10, ModbusValueType::kInt32, 0.001));
  c.outputs.push_back(Point("enable", ModbusTable::kCoil, 5, ModbusValueType::kUint16));
  c.outputs.push_back(Point("gain", ModbusTable::kHoldingRegister, 12, ModbusValueType::kUint16));
  return c;
}

/// The I/O thread's own view: asked at the reading's own stamp, staleness plays no part.
ModbusReading ThreadView(ModbusIoThread& io) {
  ModbusReading r;
  (void)io.LatestReading(r, -std::numeric_limits<double>::infinity());
  ModbusReading at_stamp;
  (void)io.LatestReading(at_stamp, r.stamp_s);
  return at_stamp;
}

bool Healthy(ModbusIoThread& io, std::uint64_t after_sequence = 0) {
  ModbusReading r;
  return io.LatestReading(r) == device::kFaultNone && r.sequence > after_sequence;
}

bool ThreadFault(ModbusIoThread& io) {
  const ModbusReading r = ThreadView(io);
  return r.sequence > 0 && (r.faults & device::kFaultCommunication) != 0 && r.failed_cycles >= 1;
}

TEST(ModbusIoThread, ReadsScaledInputsAndWritesScaledCommands) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  // force -12.34 N (raw -1234), position -2.5 m (raw -2500000 = 0xFFD9DA60, low word first), switch on,
  // set-point raw 30 -> 30 * 0.5 - 10 = 5.
  ASSERT_EQ(server.Control("set ir 0 64302 55904 65497"), "ok");
  ASSERT_EQ(server.Control("set di 3 1"), "ok");
  ASSERT_EQ(server.Control("set hr 20 30"), "ok");
  ModbusIoThread io(TcpConfig(server.modbus_port()));
  io.Start();
  ASSERT_TRUE(io.WaitForFirstPoll(kWaitS));
  ASSERT_TRUE(WaitFor([&] { return Healthy(io); }));
  ModbusReading r;
  ASSERT_EQ(io.LatestReading(r), device::kFaultNone);
  EXPECT_FALSE(r.stale);
  EXPECT_EQ(r.failed_cycles, 0u);
  EXPECT_NEAR(r.values[0], -12.34, 1e-9);
  EXPECT_NEAR(r.values[1], -2.5, 1e-9);
  EXPECT_EQ(r.values[2], 1.0);
  EXPECT_NEAR(r.values[3], 5.0, 1e-12);
  EXPECT_TRUE(r.outputs_safe) << "no command yet: the safe values go out";

  ModbusCommand command;
  command.values = {-1.5, 1.0, 7.0};  // -1500 mNm = 0xFFFFFA24 (high word first), enable, gain 7
  io.PublishCommand(command);
  EXPECT_TRUE(WaitFor([&] { return server.Control("get hr 10 3") == "65535 64036 7"; }))
      << server.Control("get hr 10 3");
  EXPECT_TRUE(WaitFor([&] { return server.Control("get co 5 1") == "1"; }));
  EXPECT_TRUE(WaitFor([&] {
    ModbusReading now;
    (void)io.LatestReading(now);
    return !now.outputs_safe;
  }));

  // An input changes: the next poll reports it.
  ASSERT_EQ(server.Control("set ir 0 500"), "ok");
  EXPECT_TRUE(WaitFor([&] {
    ModbusReading now;
    return io.LatestReading(now) == device::kFaultNone && std::abs(now.values[0] - 5.0) < 1e-9;
  }));
  const ModbusCounters c = io.counters();
  EXPECT_GT(c.polls_ok, 0u);
  EXPECT_GE(c.commands_received, 1u);
  EXPECT_EQ(c.timeouts + c.exceptions + c.disconnects + c.protocol_errors + c.connect_failures, 0u);
  EXPECT_EQ(c.connects, 1u);
  EXPECT_EQ(c.fault_entries, 0u);
}

TEST(ModbusIoThread, SafeValuesBeforeTheFirstCommandAfterCommandTimeoutAndOnStop) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusConfig config = TcpConfig(server.modbus_port());
  config.outputs[0].safe_value = 0.25;  // raw 250
  config.command_timeout_ms = 100.0;
  ModbusIoThread io(config);
  io.Start();
  ASSERT_TRUE(WaitFor([&] { return server.Control("get hr 10 2") == "0 250"; }));
  ModbusCommand command;
  command.values = {1.0, 1.0, 3.0};
  io.PublishCommand(command);
  ASSERT_TRUE(WaitFor([&] { return server.Control("get hr 10 3") == "0 1000 3"; }));
  // The loop stops publishing: after command_timeout_ms the thread falls back to the safe values, once.
  ASSERT_TRUE(WaitFor([&] { return server.Control("get hr 10 3") == "0 250 0"; }));
  EXPECT_EQ(io.counters().command_timeouts, 1u);
  EXPECT_TRUE(WaitFor([&] {  // published at the end of the cycle that wrote them
    ModbusReading r;
    (void)io.LatestReading(r);
    return r.outputs_safe;
  }));
  // A new command takes over again; Stop() writes the safe values on the way out.
  io.PublishCommand(command);
  ASSERT_TRUE(WaitFor([&] { return server.Control("get hr 10 3") == "0 1000 3"; }));
  io.Stop();
  EXPECT_EQ(server.Control("get hr 10 3"), "0 250 0");
  EXPECT_EQ(server.Control("get co 5 1"), "0");
}

TEST(ModbusIoThread, NonFiniteAndOutOfRangeCommandsAreCountedAndReplaced) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusConfig config = TcpConfig(server.modbus_port());
  config.outputs[0].safe_value = -0.5;  // raw -500 = 0xFFFFFE0C
  ModbusIoThread io(config);
  io.Start();
  ModbusCommand command;
  command.values = {std::numeric_limits<double>::quiet_NaN(), 1.0, 70000.0};  // gain above uint16
  io.PublishCommand(command);
  ASSERT_TRUE(WaitFor([&] { return server.Control("get hr 10 3") == "65535 65036 65535"; }))
      << server.Control("get hr 10 3");
  const ModbusCounters c = io.counters();
  EXPECT_EQ(c.non_finite_commands, 1u);
  EXPECT_EQ(c.clamped_commands, 1u);
}

/// Healthy first; then the server misbehaves in `mode`; the I/O thread itself must report the fault (not only
/// staleness) and count the failure kind; then the server recovers and so must the reading.
ModbusCounters FaultThenRecovery(ModbusTestServer& server, ModbusIoThread& io, const std::string& mode) {
  EXPECT_TRUE(WaitFor([&] { return Healthy(io); }));
  const ModbusCounters before = io.counters();
  EXPECT_EQ(before.fault_entries, 0u);
  EXPECT_EQ(server.Control("mode " + mode), "ok");
  EXPECT_TRUE(WaitFor([&] { return ThreadFault(io); })) << mode;
  const ModbusCounters during = io.counters();
  EXPECT_EQ(during.fault_entries, 1u) << mode;
  EXPECT_EQ(server.Control("mode normal"), "ok");
  ModbusReading faulted = ThreadView(io);
  EXPECT_TRUE(WaitFor([&] { return Healthy(io, faulted.sequence); })) << mode << ": no recovery";
  const ModbusCounters after = io.counters();
  EXPECT_EQ(after.fault_entries, 1u) << mode << ": the fault must not flap while the server misbehaves";
  return during;
}

TEST(ModbusIoThread, ServerThatStopsAnsweringIsATimeoutFault) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusIoThread io(TcpConfig(server.modbus_port()));
  io.Start();
  const ModbusCounters c = FaultThenRecovery(server, io, "stop");
  EXPECT_GE(c.timeouts, 1u);
  EXPECT_EQ(c.exceptions, 0u);
  EXPECT_GE(io.counters().connects, 2u) << "a timeout on TCP reconnects, so a late answer cannot be misread";
}

TEST(ModbusIoThread, ExceptionResponsesAreAFaultWithTheirCode) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusIoThread io(TcpConfig(server.modbus_port()));
  io.Start();
  const ModbusCounters c = FaultThenRecovery(server, io, "exception");
  EXPECT_GE(c.exceptions, 1u);
  EXPECT_EQ(c.last_exception_code, 4u);  // slave device failure, the server's default
  EXPECT_EQ(c.timeouts, 0u);
  EXPECT_EQ(c.disconnects, 0u);
  EXPECT_EQ(io.counters().connects, 1u) << "an exception is a well-formed answer: the connection stays";
}

TEST(ModbusIoThread, IllegalAddressExceptionCode) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusIoThread io(TcpConfig(server.modbus_port()));
  io.Start();
  ASSERT_TRUE(WaitFor([&] { return Healthy(io); }));
  ASSERT_EQ(server.Control("mode exception 2"), "ok");
  ASSERT_TRUE(WaitFor([&] { return ThreadFault(io); }));
  EXPECT_EQ(io.counters().last_exception_code, 2u);
}

TEST(ModbusIoThread, LateAnswersAreTimeoutFaults) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusIoThread io(TcpConfig(server.modbus_port()));  // response timeout 300 ms
  io.Start();
  const ModbusCounters c = FaultThenRecovery(server, io, "late 1000");
  EXPECT_GE(c.timeouts, 1u);
  EXPECT_EQ(c.exceptions, 0u);
  EXPECT_EQ(c.protocol_errors, 0u) << "the late answer arrives on a closed connection, never misread";
}

TEST(ModbusIoThread, DisconnectsAreFaults) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusIoThread io(TcpConfig(server.modbus_port()));
  io.Start();
  const ModbusCounters c = FaultThenRecovery(server, io, "disconnect");
  EXPECT_GE(c.disconnects, 1u);
  EXPECT_EQ(c.exceptions, 0u);
  EXPECT_GE(io.counters().connects, 2u);
}

TEST(ModbusIoThread, DeadServerIsRetriedWithBackoff) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusIoThread io(TcpConfig(server.modbus_port()));
  io.Start();
  ASSERT_TRUE(WaitFor([&] { return Healthy(io); }));
  server.Kill();  // the port now refuses connections
  ASSERT_TRUE(WaitFor([&] { return io.counters().connect_failures >= 5; }));
  EXPECT_TRUE(ThreadFault(io));
  const ModbusCounters c = io.counters();
  // Back-off 50, 100, 200, 200 ms against a 10 ms cycle: attempts are far fewer than cycles. (Bounded loosely: a
  // starved thread runs late cycles back to back, never more than one per attempt.)
  EXPECT_GE(c.cycles, 2 * c.connect_failures) << "cycles " << c.cycles << ", failed connects " << c.connect_failures;
  EXPECT_GE(c.disconnects + c.timeouts, 1u);
}

TEST(ModbusIoThread, StaleReadingIsAFaultAfterTheConfiguredAgeWhateverTheThreadDoes) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusConfig config = TcpConfig(server.modbus_port());
  config.stale_after_ms = 400.0;
  ModbusIoThread io(config);
  io.Start();
  ASSERT_TRUE(WaitFor([&] { return Healthy(io); }));
  const ModbusReading good = ThreadView(io);
  ModbusReading r;
  // On the loop's clock, relative to the reading's own stamp: deterministic.
  EXPECT_EQ(io.LatestReading(r, good.stamp_s + 0.399), device::kFaultNone);
  EXPECT_FALSE(r.stale);
  EXPECT_EQ(io.LatestReading(r, good.stamp_s + 0.400 - 1e-6), device::kFaultNone) << "just inside the bound";
  const std::uint64_t stale_before = io.counters().stale_readings;
  // (The thread keeps polling: ask about a reading at least as new as `good`, at 401 ms past its own stamp.)
  (void)io.LatestReading(r, -std::numeric_limits<double>::infinity());
  EXPECT_NE(io.LatestReading(r, r.stamp_s + 0.401) & device::kFaultCommunication, 0u);
  EXPECT_TRUE(r.stale);
  EXPECT_NE(io.LatestReading(r, std::numeric_limits<double>::quiet_NaN()) & device::kFaultCommunication, 0u);
  EXPECT_EQ(io.counters().stale_readings, stale_before + 2);
}

TEST(ModbusIoThread, BlockedThreadIsCaughtByStalenessBeforeItNotices) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusConfig config = TcpConfig(server.modbus_port());
  config.response_timeout_ms = 2000.0;  // the thread will sit in one transaction for 2 s...
  config.stale_after_ms = 2100.0;       // ...the loop's bound does not depend on it ending
  ModbusIoThread io(config);
  io.Start();
  ASSERT_TRUE(WaitFor([&] { return Healthy(io); }));
  // Counted before the switch: the first request to go unanswered comes after it.
  const std::uint64_t requests = std::stoull(server.Control("requests"));
  ASSERT_EQ(server.Control("mode stop"), "ok");
  ASSERT_TRUE(WaitFor([&] { return std::stoull(server.Control("requests")) > requests; }));
  // The thread now waits for an answer that does not come: no timeout counted yet, no fault from the thread...
  const ModbusReading r = ThreadView(io);
  const ModbusCounters during = io.counters();
  EXPECT_EQ(during.timeouts, 0u);
  EXPECT_EQ(r.faults, device::kFaultNone);
  // ...yet the loop reads a communication fault once the newest good poll is older than stale_after_ms.
  ModbusReading seen;
  EXPECT_NE(io.LatestReading(seen, r.stamp_s + 2.101) & device::kFaultCommunication, 0u);
  EXPECT_TRUE(seen.stale);
  // And the thread's own bound: the transaction ends as a counted timeout.
  EXPECT_TRUE(WaitFor([&] { return ThreadFault(io); }));
  EXPECT_GE(io.counters().timeouts, 1u);
}

TEST(ModbusIoThread, LoopSideCallsDoNotAllocate) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusIoThread io(TcpConfig(server.modbus_port()));
  io.Start();
  ASSERT_TRUE(WaitFor([&] { return Healthy(io); }));
  ModbusCommand command;
  ModbusReading r;
  std::uint32_t faults = 0;
  {
    test::AllocationCounter counter;
    for (int i = 0; i < 1000; ++i) {
      command.values[0] = 0.001 * i;
      io.PublishCommand(command);
      faults |= io.LatestReading(r);
    }
    EXPECT_EQ(counter.count(), 0u);
  }
  EXPECT_EQ(faults, device::kFaultNone);
}

TEST(ModbusIoThread, ConfigErrorsAreReportedAtConstruction) {
  ModbusConfig c = TcpConfig(502);
  c.outputs.push_back(Point("bad", ModbusTable::kInputRegister, 0, ModbusValueType::kUint16));
  EXPECT_THROW(ModbusIoThread io(c), Error);
  c = TcpConfig(502);
  c.outputs.push_back(Point("overlaps_torque", ModbusTable::kHoldingRegister, 11, ModbusValueType::kUint16));
  try {
    ModbusIoThread io(c);
    FAIL() << "overlapping outputs accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("overlap"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace teleop::fieldbus
