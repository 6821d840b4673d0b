// Speed of the stability analysis (prints numbers; not a test). docs/stability.md records the results.
//   build/bin/analysis_benchmark --benchmark_min_time=1

#include <benchmark/benchmark.h>

#include <vector>

#include "teleop/analysis/damping_ratio.hpp"
#include "teleop/analysis/discrete_model.hpp"
#include "teleop/analysis/human_bounds.hpp"
#include "teleop/analysis/limit_sweep.hpp"
#include "teleop/analysis/stability_limit.hpp"

namespace {

using namespace teleop::analysis;

SampledTeleoperator Fig7System(int delay) {
  SampledTeleoperator system;
  system.rate_hz = 1000.0;
  system.gains = LawGains::Symmetric(600.0, 2.0);
  system.peer_delay_samples = delay;
  return system;
}

// One model: assemble A and its eigenvalues (the unit of work of the search).
void BM_OneModelEigenvalues(benchmark::State& state) {
  const SampledTeleoperator system = Fig7System(0);
  const ZohBlock master = DiscretizeMasterWithHuman(system, HumanModel{0.006, 1.5, 300.0, 5.0});
  const ZohBlock slave = DiscretizeSlave(system);
  for (auto _ : state) {
    benchmark::DoNotOptimize(SpectralRadius(AssembleStateMatrix(system, master, slave)));
  }
}
BENCHMARK(BM_OneModelEigenvalues);

// Issue 32: one model with d samples of peer delay each way (the delay-line model, 8 + 2d states): assemble A and its
// spectral radius. Arg: d (10 ms, 40 ms, 100 ms at 1 kHz). O(n³): the counter `states` is n.
void BM_DelayLineModel(benchmark::State& state) {
  SampledTeleoperator system = Fig7System(0);
  system.gains = LawGains::Symmetric(50.0, 1.0);
  system.peer_delay_samples = static_cast<int>(state.range(0));
  const ZohBlock master = DiscretizeMasterWithHuman(system, HumanModel{0.006, 1.5, 300.0, 5.0});
  const ZohBlock slave = DiscretizeSlave(system);
  for (auto _ : state) {
    benchmark::DoNotOptimize(SpectralRadius(AssembleDelayedStateMatrix(system, master, slave)));
  }
  state.counters["states"] = DelayedStateDimension(system);
}
BENCHMARK(BM_DelayLineModel)->ArgName("d")->Arg(2)->Arg(10)->Arg(40)->Arg(100)->Unit(benchmark::kMillisecond);

// One limit over 64 operators (steps 2) with d samples of delay each way, 1 thread: what the run-time re-check costs.
void BM_DelayedLimit64(benchmark::State& state) {
  const auto humans = MakeHumanGrid(DefaultFingerBounds(), 2);
  SampledTeleoperator system = Fig7System(0);
  system.gains = LawGains::Symmetric(50.0, 1.0);
  system.peer_delay_samples = static_cast<int>(state.range(0));
  LimitOptions options;
  options.threads = 1;
  for (auto _ : state) {
    benchmark::DoNotOptimize(FindMaxStableStiffness(system, FixtureSide::kSlave, humans, options));
  }
}
BENCHMARK(BM_DelayedLimit64)->ArgName("d")->Arg(10)->Arg(40)->Unit(benchmark::kMillisecond)->Iterations(1);

// One worst-case limit over the default 512 operators; arg 0: side (0 master, 1 slave), arg 1: threads,
// arg 2: peer delay.
void BM_WorstCaseLimit512(benchmark::State& state) {
  const auto humans = MakeHumanGrid(DefaultFingerBounds(), 4);
  const FixtureSide side = state.range(0) == 0 ? FixtureSide::kMaster : FixtureSide::kSlave;
  LimitOptions options;
  options.threads = static_cast<int>(state.range(1));
  const SampledTeleoperator system = Fig7System(static_cast<int>(state.range(2)));
  int models = 0;
  for (auto _ : state) {
    const StabilityLimit limit = FindMaxStableStiffness(system, side, humans, options);
    models = limit.models_evaluated;
    benchmark::DoNotOptimize(limit.max_stable_stiffness_N_per_m);
  }
  state.counters["operators"] = static_cast<double>(humans.size());
  state.counters["models"] = models;
}
BENCHMARK(BM_WorstCaseLimit512)
    ->ArgNames({"slave", "threads", "delay"})
    ->Args({0, 1, 0})
    ->Args({1, 1, 0})
    ->Args({0, 2, 0})
    ->Args({1, 2, 0})
    ->Args({0, 2, 1})
    ->Args({1, 2, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// A whole Fig. 7 curve: slave limit at 10 rates, 250..4000 Hz, K_p = 600 N/m, K_d = 2 N·s/m, 512 operators.
void BM_Fig7Curve10Rates(benchmark::State& state) {
  const auto humans = MakeHumanGrid(DefaultFingerBounds(), 4);
  const std::vector<double> rates{250, 500, 750, 1000, 1250, 1500, 2000, 2500, 3000, 4000};
  LimitOptions options;
  options.threads = static_cast<int>(state.range(0));
  const SampledTeleoperator system = Fig7System(0);
  for (auto _ : state) {
    benchmark::DoNotOptimize(SweepLimit(system, FixtureSide::kSlave, humans, SweepVariable::kRateHz, rates, options));
  }
}
BENCHMARK(BM_Fig7Curve10Rates)->ArgName("threads")->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
