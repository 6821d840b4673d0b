// CAN link numbers (GitHub issue 4): bits on the wire per cycle against the theoretical minimum for the payload,
// the highest DOF count that fits at 1 kHz within 70 % load on classic 1 Mbit/s and CAN FD 1/5 Mbit/s, and the
// encode/decode time per cycle. Prints the budget table first, then runs Google Benchmark.
#include <benchmark/benchmark.h>

#include <array>
#include <cstdio>

#include "teleop/proto/can/bus_load.hpp"
#include "teleop/proto/can/sample_codec.hpp"
#include "teleop/transport/can_emulated_bus.hpp"
#include "teleop/transport/can_link.hpp"

namespace {

using namespace teleop;
using proto::can::CanWireFormat;

CanWireFormat Format(int dof, bool fd) {
  CanWireFormat f{};
  f.dof = dof;
  f.fd = fd;
  return f;
}

proto::SampleMessage Sample(int dof) {
  proto::SampleMessage m{};
  m.dof = static_cast<std::uint8_t>(dof);
  m.flags = proto::kFlagEnabled;
  for (int d = 0; d < dof; ++d) {
    const auto j = static_cast<std::size_t>(d);
    m.position_m[j] = 0.01 * (d + 1);
    m.velocity_m_per_s[j] = -0.1 * (d + 1);
    m.force_N[j] = 0.5 * (d + 1);
  }
  return m;
}

void PrintBudget() {
  const proto::can::CanBitrates rates{1e6, 5e6};
  std::printf("CAN budget at 1000 Hz, bilateral (both directions), worst-case bit stuffing, 11-bit IDs\n");
  std::printf("minimum = cheapest frames of the same kind holding the payload bits (dof*37 + 6 flags + 4 counter)\n");
  std::printf("%-8s %4s %7s %8s %10s %10s %9s %8s\n", "bus", "dof", "frames", "bytes", "wire_bits", "min_bits",
              "overhead", "load_%");
  for (const bool fd : {false, true}) {
    for (int dof = 1; dof <= proto::kMaxWireDof; ++dof) {
      const proto::can::BusLoad b = proto::can::ComputeBusLoad(Format(dof, fd), rates, 1000.0);
      std::printf("%-8s %4d %7d %8d %10d %10d %8.3fx %8.1f\n", fd ? "FD 1/5M" : "classic", dof, b.frames_per_cycle,
                  b.data_bytes_per_cycle, b.wire_bits_per_cycle, b.minimum_bits_per_cycle, b.overhead, 100.0 * b.load);
    }
  }
  const int classic = proto::can::MaxDofWithinLoad(Format(1, false), rates, 1000.0, 0.70, 64);
  const int fd_wire = proto::can::MaxDofWithinLoad(Format(1, true), rates, 1000.0, 0.70, proto::kMaxWireDof);
  const int fd_bus = proto::can::MaxDofWithinLoad(Format(1, true), rates, 1000.0, 0.70, 64);
  std::printf(
      "highest DOF at 1 kHz within 70 %%: classic 1 Mbit/s: %d; CAN FD 1/5 Mbit/s: %d (wire format limit %d; "
      "the bus alone would carry %d)\n",
      classic, fd_wire, proto::kMaxWireDof, fd_bus);
  const proto::can::BusLoad three = proto::can::ComputeBusLoad(Format(3, false), rates, 1000.0);
  std::printf(
      "target 3-DOF bilateral at 1 kHz on classic 1 Mbit/s within 70 %%: %.1f %% -> %s; overhead %.3fx (target "
      "<= 1.1x)\n\n",
      100.0 * three.load, three.load <= 0.70 ? "met" : "NOT met", three.overhead);
  std::fflush(stdout);
}

void BM_EncodeCycle(benchmark::State& state) {
  const int dof = static_cast<int>(state.range(0));
  const CanWireFormat f = Format(dof, state.range(1) != 0);
  proto::SampleMessage m = Sample(dof);
  std::array<proto::can::CanFrame, proto::can::kMaxSlots> frames{};
  for (auto _ : state) {
    ++m.sequence;
    benchmark::DoNotOptimize(proto::can::EncodeCycle(m, f, frames));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_EncodeCycle)->ArgNames({"dof", "fd"})->Args({3, 0})->Args({6, 0})->Args({3, 1})->Args({6, 1});

void BM_DecodeCycle(benchmark::State& state) {
  const int dof = static_cast<int>(state.range(0));
  const CanWireFormat f = Format(dof, state.range(1) != 0);
  proto::SampleMessage m = Sample(dof);
  std::array<std::array<proto::can::CanFrame, proto::can::kMaxSlots>, 16> cycles{};
  int frames = 0;
  for (std::uint32_t s = 0; s < cycles.size(); ++s) {
    m.sequence = s;
    frames = proto::can::EncodeCycle(m, f, cycles[s]).frames;
  }
  proto::can::CycleAssembler rx(f, proto::SenderRole::kMaster);
  proto::SampleMessage out{};
  std::size_t i = 0;
  for (auto _ : state) {
    const auto& c = cycles[i++ % cycles.size()];
    for (int k = 0; k < frames; ++k) benchmark::DoNotOptimize(rx.Push(c[static_cast<std::size_t>(k)], out));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_DecodeCycle)->ArgNames({"dof", "fd"})->Args({3, 0})->Args({6, 0})->Args({3, 1})->Args({6, 1});

// One bilateral cycle through two CanLinks on the in-process emulated bus (encode, arbitration, reassembly,
// sequence tracking), with simulated time.
void BM_LinkCycleOnEmulatedBus(benchmark::State& state) {
  const int dof = static_cast<int>(state.range(0));
  const CanWireFormat f = Format(dof, state.range(1) != 0);
  std::uint64_t now_ns = 0;
  transport::EmulatedCanBus bus(transport::EmulatedCanBusConfig{}, [&now_ns] { return now_ns; });
  const int a = bus.AddNode();
  const int b = bus.AddNode();
  transport::CanLink master(f, proto::SenderRole::kMaster, bus.MakePort(a));
  transport::CanLink slave(f, proto::SenderRole::kSlave, bus.MakePort(b));
  proto::SampleMessage m = Sample(dof);
  proto::SampleMessage out{};
  for (auto _ : state) {
    ++m.sequence;
    benchmark::DoNotOptimize(master.Send(m));
    benchmark::DoNotOptimize(slave.Send(m));
    now_ns += 1'000'000;
    benchmark::DoNotOptimize(slave.Poll(out));
    benchmark::DoNotOptimize(master.Poll(out));
  }
  state.counters["accepted"] = static_cast<double>(slave.counters().accepted);
}
BENCHMARK(BM_LinkCycleOnEmulatedBus)->ArgNames({"dof", "fd"})->Args({3, 0})->Args({3, 1});

}  // namespace

int main(int argc, char** argv) {
  PrintBudget();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
