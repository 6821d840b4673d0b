// A master and a slave TeleopNode running their real loops in two threads over the emulated CAN bus (teleop-canbus's
// core, CanBusServer, in a third thread; each node a UdpCanBusPort, as two processes with transport emulated-can):
// with sync.mode triggered the slave's cycle starts when the master's whole cycle of frames has arrived, so the
// sample its law uses is fresh; free-running it was waiting, up to a period. Measured the way the UDP pair is
// (phase_lock_test.cpp): the summary's data age (receive age: cycle start − the kernel's receive time of the
// cycle's last frame) and age in cycles. Behaviour only: the ratio of the two modes' medians within one run and
// the medians in cycles, never a duration.

#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include "teleop/config/yaml_config.hpp"
#include "teleop/node/teleop_node.hpp"
#include "teleop/transport/can_bus_server.hpp"
#include "teleop/transport/can_link.hpp"
#include "teleop/transport/can_udp_bus_port.hpp"
#include "test_utilities/mock_device.hpp"

namespace teleop::node {
namespace {

// 250 Hz (a period of 4 ms leaves a loaded machine room to wake up), 3 DOF on classic CAN at 1 Mbit/s: two frames
// per cycle and direction, 270 µs of bus time each, so the slave's trigger is the second of the master's frames.
std::string Config(const char* role, const char* sync) {
  return std::string("role: ") + role + R"(
dof: 3
rate_hz: 250
duration_s: 1.5
link:
  transport: emulated-can
  timeout_ms: 5000
  security: {mode: insecure}
law: {kp_N_per_m: 600, kd_Ns_per_m: 0, max_force_N: 0}
device: {backend: loopback, loopback: {mass_kg: 0.04, damping_Ns_per_m: 0.41}}
stability: {check: false}
sync: {mode: )" +
         sync + ", timeout_margin_us: 4000}\n";
}

struct PairSummaries {
  RunSummary master;
  RunSummary slave;
  std::uint64_t slave_partial_cycles = 0;
};

/// teleop-canbus's core on its own thread, on a free port, at 1 Mbit/s.
struct BusThread {
  BusThread() {
    transport::CanBusServerConfig config;
    config.port = 0;
    server = std::make_unique<transport::CanBusServer>(config);
    thread = std::thread([this] { server->Run(stop); });
  }
  ~BusThread() {
    stop = true;
    thread.join();
  }
  std::unique_ptr<transport::CanLink> Link(proto::SenderRole role) const {
    proto::can::CanWireFormat format{};
    format.dof = 3;
    return std::make_unique<transport::CanLink>(
        format, role, std::make_unique<transport::UdpCanBusPort>("127.0.0.1", server->port(), 2000));
  }
  std::unique_ptr<transport::CanBusServer> server;
  std::atomic<bool> stop{false};
  std::thread thread;
};

PairSummaries RunPair(const char* sync) {
  const BusThread bus;
  auto master_link = bus.Link(proto::SenderRole::kMaster);
  auto slave_link = bus.Link(proto::SenderRole::kSlave);
  const transport::CanLink* slave_can = slave_link.get();
  config::ProcessConfig slave_config = config::ParseProcessConfig(Config("slave", sync), "slave.yaml");
  slave_config.loop.duration_s = 30.0;  // stops on the master's clean shutdown
  TeleopNode master(config::ParseProcessConfig(Config("master", sync), "master.yaml"),
                    std::make_unique<test::MockDevice>(3), std::move(master_link));
  TeleopNode slave(slave_config, std::make_unique<test::MockDevice>(3), std::move(slave_link));
  PairSummaries out;
  std::thread slave_thread([&] { out.slave = slave.Run(); });
  out.master = master.Run();
  slave_thread.join();
  out.slave_partial_cycles = slave_can->can_counters().partial_cycles;
  return out;
}

std::uint64_t Sum(const std::array<std::uint64_t, 4>& a) { return a[0] + a[1] + a[2] + a[3]; }

int Median(const std::array<std::uint64_t, 4>& a) {
  const std::uint64_t total = Sum(a);
  std::uint64_t seen = 0;
  for (int i = 0; i < 4; ++i) {
    seen += a[static_cast<std::size_t>(i)];
    if (2 * seen >= total) return i;
  }
  return 3;
}

void ExpectCoupled(const RunSummary& s) {
  ASSERT_GT(s.cycles_with_peer, 10u) << "the pair never coupled";
  EXPECT_EQ(Sum(s.data_age_cycles), s.data_age_us.count) << "one age per cycle that used the peer's sample";
  EXPECT_LE(s.data_age_us.p50, s.data_age_us.p99);
}

TEST(PhaseLockCan, TriggeredByTheMastersWholeCycleTheSlavesDataIsFresherThanFreeRunning) {
  const PairSummaries free_run = RunPair("free");
  const PairSummaries triggered = RunPair("triggered");
  ExpectCoupled(free_run.slave);
  ExpectCoupled(triggered.slave);
  ExpectCoupled(triggered.master);

  EXPECT_EQ(free_run.slave.triggered_cycles + free_run.slave.trigger_timeouts, 0u);
  EXPECT_EQ(free_run.slave.data_age_cycles[0], 0u) << "a free-running cycle is never started by the sample";
  EXPECT_GE(Median(free_run.slave.data_age_cycles), 1);

  EXPECT_EQ(triggered.slave.sync, "triggered");
  EXPECT_EQ(triggered.slave.triggered_cycles + triggered.slave.trigger_timeouts, triggered.slave.cycles);
  EXPECT_GT(triggered.slave.triggered_cycles, triggered.slave.trigger_timeouts);
  EXPECT_LT(triggered.slave.trigger_timeouts_coupled, triggered.slave.cycles_with_peer / 2)
      << "coupled, the master's cycles start the slave's";
  EXPECT_EQ(Median(triggered.slave.data_age_cycles), 0) << "the slave's cycle is started by the master's sample";
  // The receive age is measured from the kernel's stamp of the cycle's last frame: triggered, the cycle starts
  // right after it; free-running, the sample waited for a uniformly distributed part of the period (p50 about
  // half a period). Both runs on the same machine in the same test: only their ratio is asserted.
  std::printf("slave data age p50/p99: triggered %.0f/%.0f us, free-running %.0f/%.0f us (period 4000 us)\n",
              static_cast<double>(triggered.slave.data_age_us.p50),
              static_cast<double>(triggered.slave.data_age_us.p99), static_cast<double>(free_run.slave.data_age_us.p50),
              static_cast<double>(free_run.slave.data_age_us.p99));
  ASSERT_GT(free_run.slave.data_age_us.p50, 0.0);
  EXPECT_LT(triggered.slave.data_age_us.p50, 0.5 * free_run.slave.data_age_us.p50)
      << "triggered p50 " << triggered.slave.data_age_us.p50 << " us, free-running p50 "
      << free_run.slave.data_age_us.p50 << " us";
  // The master stays the clock and uses the slave's reply at its next cycle.
  EXPECT_EQ(triggered.master.triggered_cycles, 0u);
  EXPECT_EQ(Median(triggered.master.data_age_cycles), 1);
  EXPECT_LT(triggered.slave_partial_cycles, triggered.slave.cycles / 10) << "the trigger never cuts a cycle";
}

}  // namespace
}  // namespace teleop::node
