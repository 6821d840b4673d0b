// teleop-loop-bench: the periodic loop alone (runtime::PeriodicLoop with an empty body) at any rate 1..100000 Hz,
// without the processes' config validation (whose rate cap is 4000 Hz), for deploy/bench.sh. Prints one JSON
// object with the wake-up jitter, period and overruns, and whether the real-time settings were applied.
//
//   teleop-loop-bench --rate 8000 --duration 3 [--fifo 80] [--cpu 1] [--lock] [--dma-latency-us 0] [--timer-slack-ns 1]
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <iostream>

#include "teleop/runtime/periodic_loop.hpp"

namespace {

void PrintDistribution(const char* name, const teleop::runtime::LatencyHistogram& h) {
  std::printf(R"("%s": {"count": %llu, "min_us": %.3f, "p50_us": %.3f, "p99_us": %.3f, "max_us": %.3f, )"
              R"("mean_us": %.3f}, )",
              name, static_cast<unsigned long long>(h.count()), static_cast<double>(h.min_ns()) / 1e3,
              static_cast<double>(h.Percentile(0.5)) / 1e3, static_cast<double>(h.Percentile(0.99)) / 1e3,
              static_cast<double>(h.max_ns()) / 1e3, h.mean_ns() / 1e3);
}

int Run(int argc, char** argv) {
  CLI::App app{"The periodic loop alone at any rate: wake-up jitter as JSON (deploy/bench.sh)"};
  teleop::runtime::PeriodicLoopConfig config;
  config.duration_s = 2.0;
  app.add_option("--rate", config.rate_hz, "Loop rate (Hz), 1..100000");
  app.add_option("--duration", config.duration_s, "Run time (s)");
  app.add_option("--fifo", config.fifo_priority, "SCHED_FIFO priority (0 = normal scheduling)");
  app.add_option("--cpu", config.cpu, "Pin to this CPU (-1 = any)");
  app.add_flag("--lock", config.lock_memory, "mlockall before the first cycle");
  app.add_option("--dma-latency-us", config.cpu_dma_latency_us, "Hold /dev/cpu_dma_latency at this value (-1 = no)");
  app.add_option("--timer-slack-ns", config.timer_slack_ns,
                 "Timer slack of the loop thread (ns; default 1 as in the processes; 0 = the inherited 50 us)");
  CLI11_PARSE(app, argc, argv);
  teleop::runtime::PeriodicLoop loop(config);
  loop.Run([](std::uint64_t, double) {});
  const teleop::runtime::CycleStats& s = loop.stats();
  std::printf(R"({"rate_hz": %.1f, "duration_s": %.3f, "fifo_priority": %d, "cpu": %d, "lock_memory": %s, )",
              config.rate_hz, config.duration_s, config.fifo_priority, config.cpu,
              config.lock_memory ? "true" : "false");
  std::printf(R"("cpu_dma_latency_us": %d, "cpu_dma_latency_held": %s, "realtime_settings_applied": %s, )",
              config.cpu_dma_latency_us, s.cpu_dma_latency_held ? "true" : "false",
              s.realtime_settings_applied ? "true" : "false");
  std::printf(R"("timer_slack_ns": %lld, )", static_cast<long long>(s.timer_slack_ns));
  PrintDistribution("jitter", s.jitter_ns);
  PrintDistribution("period", s.period_ns);
  std::printf(R"("cycles": %llu, "overruns": %llu, "skipped_slots": %llu, "overrun_fraction": %.6f})"
              "\n",
              static_cast<unsigned long long>(s.cycles), static_cast<unsigned long long>(s.overruns),
              static_cast<unsigned long long>(s.skipped_slots),
              s.cycles > 0 ? static_cast<double>(s.overruns) / static_cast<double>(s.cycles + s.skipped_slots) : 0.0);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "teleop-loop-bench: error: " << e.what() << "\n";
    return 2;
  }
}
