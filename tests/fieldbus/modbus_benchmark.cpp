// What the loop pays for the Modbus path: the mailbox exchange (one thread, and with the other end busy on a second
// thread), PublishCommand + LatestReading on a running I/O thread, and the register codec.
//   build/bin/modbus_benchmark

#include <benchmark/benchmark.h>

#include <atomic>
#include <cstdint>
#include <thread>

#include "teleop/fieldbus/modbus_codec.hpp"
#include "teleop/fieldbus/modbus_io_thread.hpp"
#include "teleop/runtime/mailbox.hpp"

namespace {

using teleop::fieldbus::ModbusCommand;
using teleop::fieldbus::ModbusReading;
using teleop::runtime::Mailbox;

void BM_MailboxWriteReadSameThread(benchmark::State& state) {
  Mailbox<ModbusReading> box;
  ModbusReading in;
  ModbusReading out;
  for (auto _ : state) {
    in.sequence += 1;
    box.Write(in);
    benchmark::DoNotOptimize(box.Read(out));
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(BM_MailboxWriteReadSameThread);

/// The loop's side (write a command, read a reading) while another thread hammers the other ends.
void BM_MailboxExchangeContended(benchmark::State& state) {
  Mailbox<ModbusCommand> commands;
  Mailbox<ModbusReading> readings;
  std::atomic<bool> stop{false};
  std::thread io([&] {
    ModbusCommand c;
    ModbusReading r;
    while (!stop.load(std::memory_order_relaxed)) {
      (void)commands.Read(c);
      r.sequence += 1;
      readings.Write(r);
    }
  });
  ModbusCommand c;
  ModbusReading r;
  for (auto _ : state) {
    c.values[0] += 1.0;
    commands.Write(c);
    benchmark::DoNotOptimize(readings.Read(r));
    benchmark::DoNotOptimize(r);
  }
  stop.store(true);
  io.join();
}
BENCHMARK(BM_MailboxExchangeContended);

/// PublishCommand + LatestReading on a started I/O thread (nothing listens on the port: the thread cycles through
/// failed connects with back-off, the loop-side cost is the same).
void BM_IoThreadLoopSide(benchmark::State& state) {
  teleop::fieldbus::ModbusConfig config;
  config.tcp.port = 1;  // refused
  teleop::fieldbus::ModbusPoint p;
  p.name = "torque";
  config.outputs.push_back(p);
  teleop::fieldbus::ModbusIoThread io(config);
  io.Start();
  ModbusCommand c;
  ModbusReading r;
  for (auto _ : state) {
    c.values[0] += 1.0;
    io.PublishCommand(c);
    benchmark::DoNotOptimize(io.LatestReading(r));
  }
  io.Stop();
}
BENCHMARK(BM_IoThreadLoopSide);

void BM_CodecEncodeDecodeInt32(benchmark::State& state) {
  teleop::fieldbus::ModbusPoint p;
  p.type = teleop::fieldbus::ModbusValueType::kInt32;
  p.scale = 0.001;
  std::uint16_t w[2] = {0, 0};
  double v = 0.0;
  for (auto _ : state) {
    v += 0.001;
    benchmark::DoNotOptimize(teleop::fieldbus::EncodePoint(p, v, w));
    benchmark::DoNotOptimize(teleop::fieldbus::DecodePoint(p, w));
  }
}
BENCHMARK(BM_CodecEncodeDecodeInt32);

}  // namespace

BENCHMARK_MAIN();
