// hybrid_sim_rig: the hybrid real rig's CAN side, simulated, on a teleop-canbus daemon, for the process tests
// (tests/device/hybrid/hybrid_fieldbus_process_test.py): two SimulatedCia402Drives (the joints' motors and
// encoders) and a SimulatedCanForceSensor (the handle sensor, answering each SYNC). The Modbus amplifier is the
// pymodbus server (tests/fieldbus/modbus_server.py).
//
//   hybrid_sim_rig --bus 127.0.0.1:47300 [--nodes 1,2] [--sensor-cob 0x190] [--sensor-scale 0.01]
//
// Prints "READY" once attached. Commands on stdin, one per line, one reply line each:
//   push FX FY       the operator's hand: the sensor reads (FX, FY) N, the joints get τ = Jᵀ F (paper geometry,
//                    joint angles 30° + θ1/5, 150° + θ2/5 from the drives' shafts), ÷ 5 at the shafts   -> ok
//   disable N        drive N leaves Operation Enabled (an external disable / STO)     -> ok
//   fault N CODE     drive N faults with EMCY CODE (hex)                              -> ok
//   sensor-silent    the force sensor stops sending                                   -> ok
//   status           -> "status T1 T2 S1 S2 RPDOS1 RPDOS2 SYNCS1 SENSOR_FRAMES" (commanded shaft torques N·m,
//                       CiA 402 states, counters)
//   quit             -> ok, then exits
#include <poll.h>
#include <unistd.h>

#include <Eigen/Core>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "device/hybrid/five_bar.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/simulated_can_force_sensor.hpp"
#include "teleop/fieldbus/simulated_cia402_drive.hpp"
#include "teleop/transport/can_udp_bus_port.hpp"

namespace {

using teleop::fieldbus::CanForceSensorConfig;
using teleop::fieldbus::SimulatedCanForceSensor;
using teleop::fieldbus::SimulatedCia402Drive;
using teleop::fieldbus::SimulatedCia402DriveConfig;

std::uint64_t NowNs() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
          .count());
}

int Run(int argc, char** argv) {
  std::string bus = "127.0.0.1:47300";
  std::vector<int> nodes{1, 2};
  unsigned sensor_cob = 0x190;
  double sensor_scale = 0.01;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    const std::string value = argv[i + 1];
    if (key == "--bus") {
      bus = value;
    } else if (key == "--nodes") {
      nodes.clear();
      std::istringstream in(value);
      for (std::string n; std::getline(in, n, ',');) nodes.push_back(std::stoi(n));
    } else if (key == "--sensor-cob") {
      sensor_cob = static_cast<unsigned>(std::stoul(value, nullptr, 0));
    } else if (key == "--sensor-scale") {
      sensor_scale = std::stod(value);
    } else {
      std::cerr << "unknown option " << key << "\n";
      return 2;
    }
  }
  if (nodes.size() != 2) {
    std::cerr << "--nodes needs two node ids\n";
    return 2;
  }
  const auto colon = bus.rfind(':');
  const std::string host = bus.substr(0, colon);
  const auto port = static_cast<std::uint16_t>(std::stoi(bus.substr(colon + 1)));

  std::vector<std::unique_ptr<teleop::transport::UdpCanBusPort>> ports;
  std::vector<std::unique_ptr<SimulatedCia402Drive>> drives;
  for (const int n : nodes) {
    SimulatedCia402DriveConfig s;
    s.node_id = static_cast<std::uint8_t>(n);
    s.joint.inertia_kg_m2 = 2e-3;       // at the drive shaft
    s.joint.viscous_Nms_per_rad = 0.1;  // a well-damped handle: slow under the test's push (the rig has no brakes here)
    ports.push_back(std::make_unique<teleop::transport::UdpCanBusPort>(host, port, 2000.0,
                                                                       SimulatedCia402Drive::ReceiveOptions(s)));
    drives.push_back(std::make_unique<SimulatedCia402Drive>(s, *ports.back()));
  }
  CanForceSensorConfig sc;
  sc.cob_id = sensor_cob;
  sc.scale_N_per_count = sensor_scale;
  auto sensor_port =
      std::make_unique<teleop::transport::UdpCanBusPort>(host, port, 2000.0, SimulatedCanForceSensor::ReceiveOptions());
  SimulatedCanForceSensor sensor(sc, *sensor_port);
  std::cout << "READY" << std::endl;

  const teleop::device::hybrid::FiveBar five_bar{teleop::device::hybrid::FiveBarConfig{}};
  constexpr double kDeg = std::numbers::pi / 180.0;
  Eigen::Vector2d push_N{0.0, 0.0};
  std::string pending;
  while (true) {
    const std::uint64_t now = NowNs();
    {
      const Eigen::Vector2d q{30.0 * kDeg + drives[0]->position_rad() / 5.0,
                              150.0 * kDeg + drives[1]->position_rad() / 5.0};
      Eigen::Matrix2d jacobian;
      Eigen::Vector2d tau{0.0, 0.0};  // no push, or a pose without a Jacobian: no hand torque
      if (push_N.squaredNorm() > 0.0 && five_bar.Jacobian(q, jacobian)) tau = jacobian.transpose() * push_N / 5.0;
      drives[0]->SetExternalTorque(tau(0));
      drives[1]->SetExternalTorque(tau(1));
    }
    for (auto& d : drives) d->Step(now);
    sensor.Step();
    pollfd p{STDIN_FILENO, POLLIN, 0};
    if (poll(&p, 1, 0) > 0) {
      char buf[256];
      const ssize_t got = read(STDIN_FILENO, buf, sizeof buf);
      if (got <= 0) return 0;  // stdin closed: the test is gone
      pending.append(buf, static_cast<std::size_t>(got));
      for (auto nl = pending.find('\n'); nl != std::string::npos; nl = pending.find('\n')) {
        std::istringstream line(pending.substr(0, nl));
        pending.erase(0, nl + 1);
        std::string cmd;
        line >> cmd;
        if (cmd == "push") {
          double fx = 0.0;
          double fy = 0.0;
          line >> fx >> fy;
          const std::array<double, 2> f{fx, fy};
          sensor.SetForce(f);
          push_N = {fx, fy};
          std::cout << "ok" << std::endl;
        } else if (cmd == "disable" || cmd == "fault") {
          int n = 0;
          line >> n;
          if (n < 1 || n > 2) {
            std::cout << "error: drive 1 or 2" << std::endl;
            continue;
          }
          if (cmd == "disable") {
            drives[static_cast<std::size_t>(n - 1)]->ForceDisable();
          } else {
            std::string code;
            line >> code;
            drives[static_cast<std::size_t>(n - 1)]->InjectFault(
                static_cast<std::uint16_t>(std::stoul(code.empty() ? "0x5530" : code, nullptr, 16)));
          }
          std::cout << "ok" << std::endl;
        } else if (cmd == "sensor-silent") {
          sensor.SetSilent(true);
          std::cout << "ok" << std::endl;
        } else if (cmd == "status") {
          std::printf("status %.6f %.6f %d %d %llu %llu %llu %llu\n", drives[0]->commanded_torque_Nm(),
                      drives[1]->commanded_torque_Nm(), static_cast<int>(drives[0]->drive_state()),
                      static_cast<int>(drives[1]->drive_state()),
                      static_cast<unsigned long long>(drives[0]->counters().rpdos),
                      static_cast<unsigned long long>(drives[1]->counters().rpdos),
                      static_cast<unsigned long long>(drives[0]->counters().syncs),
                      static_cast<unsigned long long>(sensor.frames_sent()));
          std::fflush(stdout);
        } else if (cmd == "quit") {
          std::cout << "ok" << std::endl;
          return 0;
        } else {
          std::cout << "error: unknown command '" << cmd << "'" << std::endl;
        }
      }
    }
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "hybrid_sim_rig: " << e.what() << "\n";
    return 1;
  }
}
