// What the I/O thread writes, read back with an independent Modbus client (mbpoll, Debian), and what mbpoll writes,
// read by the I/O thread: the register map's encoding (type, word order, scale) checked against a second tool.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "modbus_test_server.hpp"
#include "teleop/fieldbus/modbus_io_thread.hpp"

namespace teleop::fieldbus {
namespace {

using test::ModbusTestServer;
using test::RunCommand;

bool WaitFor(const std::function<bool()>& done, double timeout_s = 20.0) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return done();
}

/// Runs mbpoll once against the server (0-based addresses, one poll) and returns the value printed for `address`
/// ("[ADDR]: \tVALUE"); "" when mbpoll failed.
std::string Mbpoll(const ModbusTestServer& server, const std::vector<std::string>& args, int address) {
  std::vector<std::string> argv = {TELEOP_MBPOLL, "-m", "tcp", "-p", std::to_string(server.modbus_port()), "-a", "1",
                                   "-0",          "-1", "-o",  "5"};
  argv.insert(argv.end(), args.begin(), args.end());
  argv.push_back("127.0.0.1");
  int code = -1;
  const std::string out = RunCommand(argv, 30.0, &code);
  EXPECT_EQ(code, 0) << out;
  const std::string tag = "[" + std::to_string(address) + "]:";
  const std::size_t at = out.find(tag);
  if (at == std::string::npos) return {};
  std::size_t begin = out.find_first_not_of(" \t", at + tag.size());
  std::size_t end = out.find_first_of(" \n", begin);
  return out.substr(begin, end - begin);
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

TEST(ModbusMbpoll, ReadsBackWhatTheIoThreadWritesAndWritesWhatItReads) {
  ModbusTestServer server = ModbusTestServer::Tcp();
  ModbusConfig c;
  c.tcp.port = server.modbus_port();
  c.stale_after_ms = 2000.0;
  c.command_timeout_ms = 0.0;
  c.outputs.push_back(Point("torque_Nm", ModbusTable::kHoldingRegister, 10, ModbusValueType::kInt32, 0.001));
  ModbusPoint swapped = Point("speed", ModbusTable::kHoldingRegister, 30, ModbusValueType::kInt32, 0.01);
  swapped.word_order = ModbusWordOrder::kLowWordFirst;
  c.outputs.push_back(swapped);
  c.outputs.push_back(Point("enable", ModbusTable::kCoil, 5, ModbusValueType::kUint16));
  c.outputs.push_back(Point("current_A", ModbusTable::kHoldingRegister, 40, ModbusValueType::kInt16, 0.1));
  c.inputs.push_back(Point("setpoint", ModbusTable::kHoldingRegister, 20, ModbusValueType::kUint16, 0.5, -10.0));
  ModbusIoThread io(c);
  io.Start();
  ModbusCommand command;
  command.values = {-1.5, -123.45, 1.0, -2.3};
  io.PublishCommand(command);
  ASSERT_TRUE(WaitFor([&] { return server.Control("get co 5 1") == "1"; }));

  // mbpoll: -B is high word first; without it, low word first.
  EXPECT_EQ(Mbpoll(server, {"-t", "4:int", "-B", "-r", "10", "-c", "1"}, 10), "-1500");
  EXPECT_EQ(Mbpoll(server, {"-t", "4:int", "-r", "30", "-c", "1"}, 30), "-12345");
  EXPECT_EQ(Mbpoll(server, {"-t", "0", "-r", "5", "-c", "1"}, 5), "1");
  EXPECT_EQ(Mbpoll(server, {"-t", "4", "-r", "40", "-c", "1"}, 40).substr(0, 5), "65513");  // -23 as uint16

  // mbpoll writes the set-point register: the I/O thread reads 50 * 0.5 - 10 = 15.
  int code = -1;
  RunCommand({TELEOP_MBPOLL, "-m", "tcp", "-p", std::to_string(server.modbus_port()), "-a", "1", "-0", "-1", "-t", "4",
              "-r", "20", "127.0.0.1", "50"},
             30.0, &code);
  EXPECT_EQ(code, 0);
  EXPECT_TRUE(WaitFor([&] {
    ModbusReading r;
    return io.LatestReading(r) == device::kFaultNone && std::abs(r.values[0] - 15.0) < 1e-12;
  }));
}

}  // namespace
}  // namespace teleop::fieldbus
