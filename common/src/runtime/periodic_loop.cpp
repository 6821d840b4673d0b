#include "teleop/runtime/periodic_loop.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
#include <limits>
#include <optional>
#include <string>
#include <system_error>

#include "teleop/error.hpp"

namespace teleop::runtime {

namespace {

constexpr std::int64_t kNsPerS = 1'000'000'000;
constexpr double kMinRateHz = 1.0;
constexpr double kMaxRateHz = 100'000.0;
/// Stack pre-faulted after mlockall so the first cycles do not take page faults on a fresh stack.
constexpr std::size_t kPrefaultStackBytes = std::size_t{256} * 1024;

std::string OsReason(int error_number) {
  return std::system_category().message(error_number) + " (errno " + std::to_string(error_number) + ")";
}

timespec ToTimespec(std::int64_t ns) noexcept {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(ns / kNsPerS);
  ts.tv_nsec = static_cast<long>(ns % kNsPerS);
  return ts;
}

/// Sleeps until the absolute monotonic time `wake_ns`. Returns false when a signal interrupted the sleep and the
/// loop is stopping.
bool SleepUntil(std::int64_t wake_ns, const std::atomic<bool>& stop) noexcept {
  const timespec wake = ToTimespec(wake_ns);
  while (true) {
    const int rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr);
    if (rc == 0) return true;
    if (rc != EINTR) return true;  // EINVAL cannot happen with a normalised timespec; do not spin.
    if (stop.load(std::memory_order_relaxed)) return false;
  }
}

void PrefaultStack() noexcept {
  unsigned char stack[kPrefaultStackBytes];
  std::memset(stack, 0, sizeof(stack));
  asm volatile("" : : "r"(stack) : "memory");  // keep the writes: the point is to touch the pages
}

/// The open cpu_dma_latency request: the kernel keeps the PM QoS value while the file descriptor is open.
class DmaLatencyRequest {
 public:
  DmaLatencyRequest(const std::string& path, int latency_us) noexcept {
    fd_ = open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd_ < 0) {
      error_ = errno;
      return;
    }
    // The kernel reads a binary 32-bit value (or a hex string); the binary form is what cyclictest writes.
    const std::int32_t value = latency_us;
    if (write(fd_, &value, sizeof value) != static_cast<ssize_t>(sizeof value)) {
      error_ = errno != 0 ? errno : EIO;
      close(fd_);
      fd_ = -1;
    }
  }
  ~DmaLatencyRequest() {
    if (fd_ >= 0) close(fd_);
  }
  DmaLatencyRequest(const DmaLatencyRequest&) = delete;
  DmaLatencyRequest& operator=(const DmaLatencyRequest&) = delete;
  DmaLatencyRequest(DmaLatencyRequest&&) = delete;
  DmaLatencyRequest& operator=(DmaLatencyRequest&&) = delete;

  bool held() const noexcept { return fd_ >= 0; }
  int error() const noexcept { return error_; }

 private:
  int fd_ = -1;
  int error_ = 0;
};

}  // namespace

std::int64_t MonotonicNowNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * kNsPerS + ts.tv_nsec;
}

PeriodicLoop::PeriodicLoop(const PeriodicLoopConfig& config) : config_(config), period_s_(0.0), period_ns_(0) {
  if (!std::isfinite(config.rate_hz) || config.rate_hz < kMinRateHz || config.rate_hz > kMaxRateHz) {
    throw Error("periodic loop: rate_hz " + std::to_string(config.rate_hz) + " is outside 1..100000 Hz");
  }
  if (config.fifo_priority < 0 || config.fifo_priority > 99) {
    throw Error("periodic loop: fifo_priority " + std::to_string(config.fifo_priority) +
                " is outside 0..99 (0 = normal scheduling)");
  }
  if (config.cpu < -1) {
    throw Error("periodic loop: cpu " + std::to_string(config.cpu) + " is invalid (-1 = any CPU, else a CPU index)");
  }
  if (config.cpu_dma_latency_us < -1) {
    throw Error("periodic loop: cpu_dma_latency_us " + std::to_string(config.cpu_dma_latency_us) +
                " is invalid (-1 = leave it alone, 0 = no idle halt, else the largest wake-up latency in µs)");
  }
  if (config.timer_slack_ns < 0) {
    throw Error("periodic loop: timer_slack_ns " + std::to_string(config.timer_slack_ns) +
                " is invalid (0 = leave the inherited slack, else the slack in ns)");
  }
  if (!std::isfinite(config.duration_s) || config.duration_s < 0.0) {
    throw Error("periodic loop: duration_s " + std::to_string(config.duration_s) +
                " must be finite and >= 0 (0 = until stopped)");
  }
  period_ns_ = std::llround(1e9 / config.rate_hz);
  period_s_ = static_cast<double>(period_ns_) * 1e-9;
}

void PeriodicLoop::ApplySchedulingSettings() const {
  if (config_.cpu >= 0) {
    const long configured = sysconf(_SC_NPROCESSORS_CONF);
    if (config_.cpu >= CPU_SETSIZE || (configured > 0 && config_.cpu >= configured)) {
      throw Error("periodic loop: cpu " + std::to_string(config_.cpu) + " does not exist (this machine has " +
                  std::to_string(configured) + " CPUs, numbered from 0); set realtime.cpu to -1 or a valid index");
    }
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(static_cast<std::size_t>(config_.cpu), &set);
    const int rc = pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
    if (rc != 0) {
      throw Error("periodic loop: cannot pin the loop thread to cpu " + std::to_string(config_.cpu) + ": " +
                  OsReason(rc) + ". The CPU may be offline or outside this process's cpuset (see taskset -p " +
                  std::to_string(getpid()) + "); set realtime.cpu to -1 to run on any CPU");
    }
    cpu_set_t held;
    CPU_ZERO(&held);
    if (pthread_getaffinity_np(pthread_self(), sizeof(held), &held) != 0 || !CPU_EQUAL(&held, &set)) {
      throw Error("periodic loop: the loop thread was pinned to cpu " + std::to_string(config_.cpu) +
                  " but its affinity reads back otherwise (a cpuset may override it); set realtime.cpu to -1");
    }
  }
  if (config_.fifo_priority > 0) {
    const int max_priority = sched_get_priority_max(SCHED_FIFO);
    if (max_priority >= 0 && config_.fifo_priority > max_priority) {
      throw Error("periodic loop: fifo_priority " + std::to_string(config_.fifo_priority) +
                  " exceeds the SCHED_FIFO maximum " + std::to_string(max_priority));
    }
    sched_param param{};
    param.sched_priority = config_.fifo_priority;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
    if (rc != 0) {
      throw Error("periodic loop: cannot switch to SCHED_FIFO priority " + std::to_string(config_.fifo_priority) +
                  ": " + OsReason(rc) +
                  ". Run as root or grant CAP_SYS_NICE (sudo setcap cap_sys_nice+ep <binary>, or an rtprio "
                  "limit in /etc/security/limits.conf), or set realtime.fifo_priority: 0 for normal scheduling");
    }
    int policy = 0;
    sched_param held{};
    if (pthread_getschedparam(pthread_self(), &policy, &held) != 0 || policy != SCHED_FIFO ||
        held.sched_priority != config_.fifo_priority) {
      throw Error("periodic loop: SCHED_FIFO priority " + std::to_string(config_.fifo_priority) +
                  " was accepted but does not read back (policy " + std::to_string(policy) + ", priority " +
                  std::to_string(held.sched_priority) + "); set realtime.fifo_priority: 0 for normal scheduling");
    }
  }
  if (config_.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
      const int err = errno;
      throw Error("periodic loop: mlockall failed: " + OsReason(err) +
                  ". Run as root or grant CAP_IPC_LOCK, or raise the locked-memory limit (ulimit -l unlimited, "
                  "LimitMEMLOCK=infinity in a systemd unit); or set realtime.lock_memory: false");
    }
    PrefaultStack();
  }
}

void PeriodicLoop::ApplyRealtimeSettings() {
  ApplySchedulingSettings();
  settings_applied_ = true;
}

void PeriodicLoop::Run(const Body& body) {
  if (!settings_applied_) ApplySchedulingSettings();
  std::optional<DmaLatencyRequest> dma_latency;
  if (config_.cpu_dma_latency_us >= 0) dma_latency.emplace(config_.cpu_dma_latency_path, config_.cpu_dma_latency_us);
  stats_.cpu_dma_latency_held = dma_latency.has_value() && dma_latency->held();
  stats_.cpu_dma_latency_errno = dma_latency.has_value() ? dma_latency->error() : 0;
  stats_.setting_warnings = dma_latency.has_value() && !dma_latency->held() ? 1 : 0;
  // Timer slack: a per-thread attribute, so set here, on the thread that sleeps (docs/performance.md, "1 kHz jitter").
  if (config_.timer_slack_ns > 0 &&
      prctl(PR_SET_TIMERSLACK, static_cast<unsigned long>(config_.timer_slack_ns), 0UL, 0UL, 0UL) != 0) {
    ++stats_.setting_warnings;
  }
  stats_.timer_slack_ns = prctl(PR_GET_TIMERSLACK, 0UL, 0UL, 0UL, 0UL);
  stats_.realtime_settings_applied = config_.fifo_priority > 0 && config_.lock_memory &&
                                     (config_.cpu_dma_latency_us < 0 || stats_.cpu_dma_latency_held);
  stats_.cycles = 0;
  stats_.overruns = 0;
  stats_.skipped_slots = 0;
  stats_.period_ns.Reset();
  stats_.jitter_ns.Reset();
  stats_.compute_ns.Reset();

  stats_.triggered_cycles = 0;
  stats_.trigger_timeouts = 0;
  cycle_triggered_ = false;

  const std::int64_t start = MonotonicNowNs();
  const std::int64_t end = config_.duration_s > 0.0 ? start + std::llround(config_.duration_s * 1e9)
                                                    : std::numeric_limits<std::int64_t>::max();
  if (triggered_mode()) {
    RunTriggered(body, start, end);
  } else {
    RunFree(body, start, end);
  }
}

void PeriodicLoop::RunFree(const Body& body, std::int64_t start, std::int64_t end) {
  const std::int64_t period = period_ns_;
  std::int64_t scheduled = start;
  std::int64_t previous_wake = start;
  std::uint64_t cycle = 0;
  while (!stop_.load(std::memory_order_relaxed) && scheduled < end) {
    if (!SleepUntil(scheduled, stop_)) break;
    const std::int64_t wake = MonotonicNowNs();
    stats_.jitter_ns.Add(wake - scheduled);
    if (cycle > 0) stats_.period_ns.Add(wake - previous_wake);
    previous_wake = wake;

    body(cycle, period_s_);

    const std::int64_t done = MonotonicNowNs();
    const std::int64_t compute = done - wake;
    stats_.compute_ns.Add(compute);
    ++stats_.cycles;
    ++cycle;
    if (compute > period) ++stats_.overruns;

    scheduled += period;
    // Slots whose whole period is already over are skipped, not run back to back.
    const std::int64_t late = done - scheduled;
    if (late >= period) {
      const std::int64_t missed = late / period;
      scheduled += missed * period;
      stats_.overruns += static_cast<std::uint64_t>(missed);
      stats_.skipped_slots += static_cast<std::uint64_t>(missed);
    }
  }
}

bool PeriodicLoop::WaitForTheTrigger(std::int64_t expected_ns, std::int64_t deadline_ns) {
  if (config_.trigger_spin_ns <= 0) return trigger_(deadline_ns);
  // Sleep in the trigger until the spin window opens, then poll it without sleeping (a deadline already past).
  if (trigger_(std::min(expected_ns - config_.trigger_spin_ns, deadline_ns))) return true;
  while (!stop_.load(std::memory_order_relaxed)) {
    if (trigger_(0)) return true;
    if (MonotonicNowNs() >= deadline_ns) return false;
  }
  return false;
}

void PeriodicLoop::RunTriggered(const Body& body, std::int64_t start, std::int64_t end) {
  const std::int64_t period = period_ns_;
  TriggerSchedule::Config schedule_config;
  schedule_config.period_ns = period;
  schedule_config.timeout_margin_ns =
      config_.trigger_timeout_margin_ns > 0 ? config_.trigger_timeout_margin_ns : period / 4;
  schedule_config.min_spacing_ns = period / 2;
  TriggerSchedule schedule(schedule_config);
  schedule.Start(start);
  std::int64_t previous_wake = start;
  std::uint64_t cycle = 0;
  while (!stop_.load(std::memory_order_relaxed) && MonotonicNowNs() < end) {
    if (!SleepUntil(schedule.earliest_start_ns(), stop_)) break;
    const bool fired = WaitForTheTrigger(schedule.expected_ns(), std::min(schedule.deadline_ns(), end));
    if (stop_.load(std::memory_order_relaxed)) break;
    const std::int64_t wake = MonotonicNowNs();
    stats_.jitter_ns.Add(schedule.CycleStarted(wake, fired));
    if (cycle > 0) stats_.period_ns.Add(wake - previous_wake);
    previous_wake = wake;
    cycle_triggered_ = fired;

    body(cycle, period_s_);

    const std::int64_t compute = MonotonicNowNs() - wake;
    stats_.compute_ns.Add(compute);
    ++stats_.cycles;
    ++cycle;
    if (compute > period) ++stats_.overruns;
    stats_.triggered_cycles = schedule.triggered();
    stats_.trigger_timeouts = schedule.timeouts();
  }
}

}  // namespace teleop::runtime
