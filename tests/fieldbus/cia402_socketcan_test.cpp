// The CiA 402 client and the simulated drive on a real kernel CAN stack: two SocketCAN sockets on CAN_IFACE (vcan0
// in the qemu guest, tests/qemu/cia402_guest.sh), each with its own receive filters, the drive stepped by its own
// thread on the steady clock. Skips on a host without AF_CAN; the qemu test demands that it ran.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include "teleop/fieldbus/can_port_config.hpp"
#include "teleop/fieldbus/cia402_drive.hpp"
#include "teleop/fieldbus/simulated_cia402_drive.hpp"
#include "teleop/transport/can_socket_port.hpp"

namespace teleop::fieldbus {
namespace {

/// The simulated drive on its own socket and thread (its methods are only called from that thread).
struct DriveThread {
  explicit DriveThread(const std::string& iface, const SimulatedCia402DriveConfig& config)
      : port(OpenCanPort(CanPortConfig{transport::CanMedium::kSocketCan, iface},
                         SimulatedCia402Drive::ReceiveOptions(config))),
        drive(config, *port) {
    thread = std::thread([this] {
      const Timebase clock = Timebase::Steady();
      while (!stop.load()) {
        if (inject_fault.exchange(false)) drive.InjectFault(canopen::emcy::kOvercurrent);
        drive.Step(clock.now_ns());
        position_rad.store(drive.position_rad());
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    });
  }
  ~DriveThread() {
    stop = true;
    thread.join();
  }
  std::unique_ptr<CanPort> port;
  SimulatedCia402Drive drive;
  std::atomic<bool> stop{false};
  std::atomic<bool> inject_fault{false};
  std::atomic<double> position_rad{0.0};
  std::thread thread;
};

TEST(Cia402OnSocketCan, BringsUpAndRunsTorqueModeOnARealInterface) {
  const char* iface = std::getenv("CAN_IFACE");
  if (!transport::AfCanAvailable() || iface == nullptr) {
    GTEST_SKIP() << "needs AF_CAN and CAN_IFACE (run in the qemu guest: ctest -R qemu_cia402)";
  }
  // 50 Hz with loose timeouts: the guest's CPU is emulated (TCG) on a shared machine, and the drive thread wakes
  // every millisecond at best there.
  SimulatedCia402DriveConfig sim_config;
  Cia402DriveConfig config;
  config.cycle_period_s = 0.02;
  config.sdo.timeout_ms = 100.0;
  config.drive_heartbeat_period_ms = 50.0;
  config.heartbeat_timeout_ms = 500.0;
  config.stale_after_ms = 100.0;
  config.state_timeout_ms = 2000.0;
  DriveThread sim(iface, sim_config);
  std::unique_ptr<CanPort> port =
      OpenCanPort(CanPortConfig{transport::CanMedium::kSocketCan, iface}, Cia402Drive::ReceiveOptions(config));
  Cia402Drive drive(config, *port);
  drive.Configure();
  drive.Activate();
  ASSERT_EQ(drive.drive_state(), cia402::DriveState::kOperationEnabled);
  std::printf("%s\n", drive.Describe().c_str());

  const auto period = std::chrono::duration<double>(config.cycle_period_s);
  auto next = std::chrono::steady_clock::now();
  int ok = 0;
  int no_new = 0;
  int bad = 0;
  Cia402Reading reading{};
  const int cycles = 100;  // 2 s
  for (int k = 0; k < cycles; ++k) {
    if (drive.WriteTorque_Nm(0.1) != Cia402Status::kOk) ++bad;
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    std::this_thread::sleep_until(next);
    const Cia402Status s = drive.Read(reading);
    if (s == Cia402Status::kOk) {
      ++ok;
    } else if (s == Cia402Status::kNoNewData) {
      ++no_new;
    } else {
      ++bad;
      std::printf("cycle %d: %s\n", k, ToString(s));
    }
  }
  std::printf("cycles %d: ok %d, no new data %d, bad %d; position %.4f rad (drive %.4f), velocity %.3f rad/s\n", cycles,
              ok, no_new, bad, reading.position_rad, sim.position_rad.load(), reading.velocity_rad_per_s);
  EXPECT_EQ(bad, 0);
  // A TPDO that comes after the Read is "no new data" (the emulated guest's scheduling decides how often), never a
  // wrong or stale value; most cycles must still be fresh.
  EXPECT_GE(ok, cycles / 2);
  EXPECT_EQ(drive.counters().tpdos_rejected, 0u);
  EXPECT_EQ(drive.counters().heartbeat_timeouts, 0u);
  // 0.1 N·m − 5 mN·m Coulomb on 1e-3 kg·m², 2e-3 N·m·s/rad for ~2 s: ω → 47.5 (1 − e^{−4}) = 46.6 rad/s. The
  // reading is up to a few cycles old: 10 % tolerance.
  EXPECT_NEAR(reading.velocity_rad_per_s, 46.6, 4.7);
  EXPECT_GT(reading.position_rad, 0.0);
  EXPECT_LE(reading.position_rad, sim.position_rad.load());  // the drive has moved on since, never back
  // A drive fault on the real bus: EMCY, Fault, then recovery by fault reset.
  sim.inject_fault = true;
  Cia402Status s = Cia402Status::kOk;
  for (int k = 0; k < 50 && s != Cia402Status::kFault; ++k) {
    (void)drive.WriteTorque_Nm(0.1);
    std::this_thread::sleep_for(period);
    s = drive.Read(reading);
  }
  EXPECT_EQ(s, Cia402Status::kFault);
  EXPECT_EQ(drive.last_emergency().error_code, canopen::emcy::kOvercurrent);
  EXPECT_TRUE(drive.Deactivate());
  drive.Activate();
  EXPECT_EQ(drive.drive_state(), cia402::DriveState::kOperationEnabled);
  int ok_after = 0;
  for (int k = 0; k < 20; ++k) {
    (void)drive.WriteTorque_Nm(0.0);
    std::this_thread::sleep_for(period);
    s = drive.Read(reading);
    EXPECT_TRUE(s == Cia402Status::kOk || s == Cia402Status::kNoNewData) << ToString(s);
    ok_after += s == Cia402Status::kOk ? 1 : 0;
  }
  EXPECT_GE(ok_after, 10);
  EXPECT_TRUE(drive.Deactivate());
}

}  // namespace
}  // namespace teleop::fieldbus
