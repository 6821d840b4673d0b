// Cost of the runtime's per-cycle operations: histogram Add, ring push/pop, telemetry push.
#include <benchmark/benchmark.h>

#include <cstdint>

#include "teleop/runtime/latency_histogram.hpp"
#include "teleop/runtime/spsc_ring.hpp"
#include "teleop/runtime/telemetry.hpp"
#include "teleop/runtime/watchdog.hpp"

namespace {

using teleop::runtime::LatencyHistogram;

void BM_HistogramAdd(benchmark::State& state) {
  LatencyHistogram h;
  std::int64_t value = 0;
  for (auto _ : state) {
    h.Add(value);
    value = (value + 7919) % 12'000'000;
  }
  benchmark::DoNotOptimize(h.count());
}
BENCHMARK(BM_HistogramAdd);

void BM_HistogramPercentile(benchmark::State& state) {
  LatencyHistogram h;
  for (std::int64_t i = 0; i < 100'000; ++i) h.Add(1'000'000 + (i * 7919) % 200'000);
  for (auto _ : state) benchmark::DoNotOptimize(h.Percentile(0.99));
}
BENCHMARK(BM_HistogramPercentile);

void BM_RingPushPopTelemetryRecord(benchmark::State& state) {
  teleop::runtime::SpscRing<teleop::runtime::TelemetryRecord> ring(1024);
  teleop::runtime::TelemetryRecord record{};
  for (auto _ : state) {
    benchmark::DoNotOptimize(ring.TryPush(record));
    benchmark::DoNotOptimize(ring.TryPop(record));
  }
}
BENCHMARK(BM_RingPushPopTelemetryRecord);

void BM_WatchdogFeedFresh(benchmark::State& state) {
  teleop::runtime::LinkWatchdog w(0.05);
  double t = 0.0;
  for (auto _ : state) {
    w.Feed(t);
    benchmark::DoNotOptimize(w.Fresh(t + 1e-3));
    t += 1e-3;
  }
}
BENCHMARK(BM_WatchdogFeedFresh);

}  // namespace

BENCHMARK_MAIN();
