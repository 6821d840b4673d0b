#pragma once

// A thread that is not the real-time loop (the key-exchange helper, the event log, the telemetry writer, the Modbus
// I/O thread, the DDS bridge, ...) calls BecomeBackgroundThread() first thing. A thread inherits its creator's
// scheduling policy and CPU affinity: one started by a thread that has already applied realtime settings
// (PeriodicLoop::ApplyRealtimeSettings: SCHED_FIFO at realtime.fifo_priority, pinned to realtime.cpu) would
// otherwise run its slow work at the loop's priority on the loop's CPU and delay the cycle. It gets the scheduling
// the process was started with instead: normal scheduling for a plain start, or what the unit gave the whole process
// (deploy/systemd: CPUSchedulingPolicy=fifo, CPUSchedulingPriority=10, below the loop's 80, above normal tasks).
// The processes start every such thread before they apply the settings; this makes the order not matter (a library
// user may apply them first).
#include <pthread.h>
#include <sched.h>

namespace teleop::runtime {

namespace detail {
/// The scheduling the process was started with (policy, priority, CPU set: chrt, taskset, a cpuset, systemd's
/// CPUSchedulingPolicy= and CPUAffinity=), read before main, before any thread could change its own.
struct StartupScheduling {
  cpu_set_t cpus{};
  int policy = SCHED_OTHER;
  sched_param param{};
  bool cpus_valid = false;
  bool policy_valid = false;
  StartupScheduling() noexcept {
    CPU_ZERO(&cpus);
    cpus_valid = sched_getaffinity(0, sizeof(cpus), &cpus) == 0;
    policy_valid = pthread_getschedparam(pthread_self(), &policy, &param) == 0;
  }
};
inline const StartupScheduling kStartupScheduling{};
}  // namespace detail

/// Returns the calling thread to the process's start-up scheduling policy and priority and to its start-up CPU set,
/// where it inherited others; names it (`name`: at most 15 characters, shown by `ps -L`, `top -H` and gdb). Never
/// fails: a setting that cannot be changed is left as it was. Not for the loop.
inline void BecomeBackgroundThread(const char* name) noexcept {
  const detail::StartupScheduling& start = detail::kStartupScheduling;
  int policy = SCHED_OTHER;
  sched_param param{};
  if (start.policy_valid && pthread_getschedparam(pthread_self(), &policy, &param) == 0 &&
      (policy != start.policy || param.sched_priority != start.param.sched_priority)) {
    static_cast<void>(pthread_setschedparam(pthread_self(), start.policy, &start.param));
  }
  if (start.cpus_valid) {
    cpu_set_t now;
    CPU_ZERO(&now);
    if (pthread_getaffinity_np(pthread_self(), sizeof(now), &now) == 0 && !CPU_EQUAL(&now, &start.cpus)) {
      static_cast<void>(pthread_setaffinity_np(pthread_self(), sizeof(cpu_set_t), &start.cpus));
    }
  }
  if (name != nullptr) static_cast<void>(pthread_setname_np(pthread_self(), name));
}

}  // namespace teleop::runtime
