// Time of the CiA 402 client's cycle calls on the in-process emulated bus: Write (RPDO + SYNC), Read (drain the
// TPDOs, checks), and, for scale, the simulated drive's answer to one SYNC. Prints numbers; asserts nothing.
#include <benchmark/benchmark.h>

#include "cia402_test_rig.hpp"

namespace {

using teleop::fieldbus::test::Cia402Rig;

void BM_Cia402WriteAdvanceRead(benchmark::State& state) {
  Cia402Rig rig;
  rig.Build();
  rig.BringUp();
  for (auto _ : state) {
    const Cia402Rig::CycleResult r = rig.Cycle(0.05);
    benchmark::DoNotOptimize(r);
  }
  state.SetLabel("one 1 kHz cycle: client Write + 10 drive steps + bus + client Read");
}
BENCHMARK(BM_Cia402WriteAdvanceRead);

void BM_Cia402ClientOnly(benchmark::State& state) {
  Cia402Rig rig;
  rig.Build();
  rig.BringUp();
  teleop::fieldbus::Cia402Reading reading{};
  for (auto _ : state) {
    state.PauseTiming();
    rig.Advance(1'000'000);  // the drive answers the previous SYNC
    state.ResumeTiming();
    benchmark::DoNotOptimize(rig.drive->Read(reading));
    benchmark::DoNotOptimize(rig.drive->WriteTorque_Nm(0.05));
  }
  state.SetLabel("client Read (2 TPDOs) + Write (RPDO + SYNC) on the in-process bus");
}
BENCHMARK(BM_Cia402ClientOnly);

}  // namespace

BENCHMARK_MAIN();
