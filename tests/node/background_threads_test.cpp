// Threads that are not the loop leave the loop's scheduling (teleop/runtime/background_thread.hpp): started by a
// thread that already runs SCHED_FIFO 10 pinned to CPU 0 (what PeriodicLoop::ApplyRealtimeSettings makes of the
// loop thread), the key-exchange helper, the event log and the telemetry writer run the policy, priority and CPU set
// the process started with, under their own names: SCHED_OTHER as ctest starts it, SCHED_FIFO 5 when ctest runs it
// under `chrt --fifo 5` (node.BackgroundThreads.UnderChrtFifo5, as a systemd unit's CPUSchedulingPolicy= starts the
// process). Needs CAP_SYS_NICE for SCHED_FIFO (root here); skips otherwise.
#include <dirent.h>
#include <gtest/gtest.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "teleop/node/event_log.hpp"
#include "teleop/runtime/background_thread.hpp"
#include "teleop/runtime/telemetry.hpp"
#include "teleop/transport/secure_session.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop {
namespace {

struct ThreadFacts {
  pid_t tid = 0;
  int policy = -1;
  int priority = -1;
  bool startup_cpus = false;
  std::string name;
};

std::vector<ThreadFacts> OtherThreads() {
  std::vector<ThreadFacts> out;
  const pid_t self = static_cast<pid_t>(gettid());
  DIR* dir = opendir("/proc/self/task");
  if (dir == nullptr) return out;
  while (const dirent* entry = readdir(dir)) {
    if (entry->d_name[0] == '.') continue;
    ThreadFacts t;
    t.tid = static_cast<pid_t>(std::stoi(entry->d_name));
    if (t.tid == self || t.tid == getpid()) continue;  // the test thread and gtest's main thread
    t.policy = sched_getscheduler(t.tid);
    sched_param p{};
    t.priority = sched_getparam(t.tid, &p) == 0 ? p.sched_priority : -1;
    cpu_set_t set;
    CPU_ZERO(&set);
    t.startup_cpus =
        sched_getaffinity(t.tid, sizeof(set), &set) == 0 && CPU_EQUAL(&set, &runtime::detail::kStartupScheduling.cpus);
    std::ifstream comm("/proc/self/task/" + std::string(entry->d_name) + "/comm");
    std::getline(comm, t.name);
    out.push_back(t);
  }
  closedir(dir);
  return out;
}

/// The thread runs the policy and priority the process started with (SCHED_OTHER 0 under ctest; what the systemd unit
/// gives the whole process in a deployment).
bool StartupPolicy(const ThreadFacts& t) {
  const auto& start = runtime::detail::kStartupScheduling;
  return t.policy == start.policy && t.priority == start.param.sched_priority;
}

/// Runs `body` on a thread that first makes itself SCHED_FIFO 10 on CPU 0; false when it may not.
bool RunAsRealtimeThread(const std::function<void()>& body) {
  bool ok = false;
  std::thread([&] {
    sched_param p{};
    p.sched_priority = 10;
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(0, &one);
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) != 0) return;
    if (pthread_setaffinity_np(pthread_self(), sizeof(one), &one) != 0) return;
    ok = true;
    body();
  }).join();
  return ok;
}

TEST(BackgroundThreads, LeaveTheLoopsSchedulingWhenStartedFromIt) {
  ASSERT_TRUE(runtime::detail::kStartupScheduling.cpus_valid && runtime::detail::kStartupScheduling.policy_valid);
  test::ScopedTempDir dir("background_threads");
  std::unique_ptr<node::EventLog> events;
  std::unique_ptr<runtime::TelemetryWriter> telemetry;
  std::unique_ptr<transport::SecureSession> session;
  std::vector<ThreadFacts> seen;
  const bool realtime = RunAsRealtimeThread([&] {
    events = std::make_unique<node::EventLog>(64);
    telemetry = std::make_unique<runtime::TelemetryWriter>(dir.File("t.csv"), 64, 1);
    transport::SecureSessionConfig config;
    config.role = proto::SenderRole::kMaster;
    config.offload_key_exchange = true;
    std::array<std::uint8_t, transport::kPreSharedKeyBytes> bytes{};
    bytes.fill(7);
    session = std::make_unique<transport::SecureSession>(config, transport::PreSharedKey(bytes));
    // Each new thread calls BecomeBackgroundThread first thing: wait (bounded) until all three have.
    for (int i = 0; i < 500; ++i) {
      seen = OtherThreads();
      int done = 0;
      for (const ThreadFacts& t : seen) done += (StartupPolicy(t) && t.startup_cpus) ? 1 : 0;
      if (seen.size() >= 3 && done == static_cast<int>(seen.size())) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  });
  if (!realtime) GTEST_SKIP() << "SCHED_FIFO not permitted (needs CAP_SYS_NICE)";
  ASSERT_GE(seen.size(), 3u);
  std::vector<std::string> names;
  for (const ThreadFacts& t : seen) {
    EXPECT_TRUE(StartupPolicy(t)) << t.name << " (tid " << t.tid << ") runs policy " << t.policy << " priority "
                                  << t.priority << ", not the process's start-up policy "
                                  << runtime::detail::kStartupScheduling.policy << " priority "
                                  << runtime::detail::kStartupScheduling.param.sched_priority;
    EXPECT_TRUE(t.startup_cpus) << t.name << " (tid " << t.tid << ") inherited the loop's CPU pinning";
    names.push_back(t.name);
  }
  for (const char* name : {"teleop-events", "teleop-telem", "teleop-kex"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
  }
}

}  // namespace
}  // namespace teleop
