#pragma once

// A thread that is not the real-time loop (the key-exchange helper, the event log, the telemetry writer, the Modbus
// I/O thread, the DDS bridge, ...) calls BecomeBackgroundThread() first thing. A thread inherits its creator's
// scheduling policy and CPU affinity: one started by a thread that has already applied realtime settings
// (PeriodicLoop::ApplyRealtimeSettings: SCHED_FIFO, pinned to realtime.cpu) would otherwise run its slow work at
// the loop's priority on the loop's CPU and delay the cycle. The processes start every such thread before they
// apply the settings; this makes the order not matter (a library user may apply them first).
#include <pthread.h>
#include <sched.h>

namespace teleop::runtime {

namespace detail {
/// The CPU set the process was started with (taskset, a cpuset, systemd's CPUAffinity=), read before main, before
/// any thread could pin itself.
struct StartupAffinity {
  cpu_set_t set{};
  bool valid = false;
  StartupAffinity() noexcept {
    CPU_ZERO(&set);
    valid = sched_getaffinity(0, sizeof(set), &set) == 0;
  }
};
inline const StartupAffinity kStartupAffinity{};
}  // namespace detail

/// Returns the calling thread to normal scheduling (SCHED_OTHER) when it inherited SCHED_FIFO or SCHED_RR, and to
/// the process's start-up CPU set when it inherited a narrower one; names it (`name`: at most 15 characters, shown
/// by `ps -L`, `top -H` and gdb). Never fails: a setting that cannot be changed is left as it was. Not for the loop.
inline void BecomeBackgroundThread(const char* name) noexcept {
  int policy = SCHED_OTHER;
  sched_param param{};
  if (pthread_getschedparam(pthread_self(), &policy, &param) == 0 && (policy == SCHED_FIFO || policy == SCHED_RR)) {
    sched_param normal{};
    normal.sched_priority = 0;
    static_cast<void>(pthread_setschedparam(pthread_self(), SCHED_OTHER, &normal));
  }
  if (detail::kStartupAffinity.valid) {
    cpu_set_t now;
    CPU_ZERO(&now);
    if (pthread_getaffinity_np(pthread_self(), sizeof(now), &now) == 0 &&
        !CPU_EQUAL(&now, &detail::kStartupAffinity.set)) {
      static_cast<void>(pthread_setaffinity_np(pthread_self(), sizeof(cpu_set_t), &detail::kStartupAffinity.set));
    }
  }
  if (name != nullptr) static_cast<void>(pthread_setname_np(pthread_self(), name));
}

}  // namespace teleop::runtime
