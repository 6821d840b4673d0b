// CAN link numbers (GitHub issue 4): bits on the wire per cycle against the theoretical minimum for the payload,
// the highest DOF count that fits at 1 kHz within 70 % load on classic 1 Mbit/s and CAN FD 1/5 Mbit/s, and the
// encode/decode time per cycle. Prints the budget table first, then runs Google Benchmark.
#include <benchmark/benchmark.h>

#include <algorithm>
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

// A triggered slave (sync.mode triggered, docs/can.md "Phase-locked cycles over CAN") fires on the master's last
// frame of a cycle: no frame is added, so the bits and the load are the table's above. Beside them, what the
// alternative of a dedicated SYNC frame after the sample (classic, 0 data bytes, 11-bit: 55 bits at the nominal
// rate, master only) would cost, and the wait on the bus until the sample is whole (one blocking frame of the
// slave's + the master's frames; + the SYNC frame in the alternative) with the start-up check's default
// peer_delay_fraction at 1 kHz ((100 us + that wait) x 1 kHz).
void PrintTriggered(const proto::can::CanBitrates& rates) {
  constexpr double kAssumedAge_s = 100e-6;  // kTriggeredDataAge_s (teleop/config/stability_check.hpp)
  const double sync_s = proto::can::FrameTime_s(false, false, false, 0, rates);
  const int sync_bits = proto::can::ClassicFrameBits(false, 0);
  std::printf(
      "\ntriggered slave over CAN at 1000 Hz (trigger = the master's last frame of the cycle; no extra frame)\n");
  std::printf("%-8s %4s %10s %8s %12s %9s | %s\n", "bus", "dof", "bits/cycle", "load_%", "complete_us", "fraction",
              "with a SYNC frame: bits/cycle load_% complete_us fraction");
  for (const bool fd : {false, true}) {
    for (int dof = 1; dof <= proto::kMaxWireDof; ++dof) {
      const proto::can::BusLoad b = proto::can::ComputeBusLoad(Format(dof, fd), rates, 1000.0);
      const int bits = 2 * b.wire_bits_per_cycle;
      const double sync_load = b.load + sync_s * 1000.0;
      const double sync_complete = b.cycle_complete_s + sync_s;
      std::printf("%-8s %4d %10d %8.1f %12.1f %9.3f | %10d %6.1f %11.1f %8.3f\n", fd ? "FD 1/5M" : "classic", dof, bits,
                  100.0 * b.load, b.cycle_complete_s * 1e6, std::min(1.0, (kAssumedAge_s + b.cycle_complete_s) * 1e3),
                  bits + sync_bits, 100.0 * sync_load, sync_complete * 1e6,
                  std::min(1.0, (kAssumedAge_s + sync_complete) * 1e3));
    }
  }
  std::printf(
      "(bits/cycle: both directions, worst-case stuffing; complete_us: from the master queueing its cycle to "
      "the slave holding all of it)\n");
}

void PrintBudget() {
  const proto::can::CanBitrates rates{1e6, 5e6};
  std::printf("CAN budget at 1000 Hz, bilateral (both directions), worst-case bit stuffing, 11-bit IDs\n");
  std::printf("minimum = cheapest frames of the same kind holding the payload bits (dof*37 + 7 flags + 4 counter)\n");
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
  PrintTriggered(rates);
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
