#pragma once

// A CiA 402 drive client and a simulated drive on one in-process emulated CAN bus, on a manual clock: the set-up
// waits advance the clock and step the drive, so a whole bring-up runs deterministically in one thread. A third
// node monitors the bus (every frame, like candump) and can write a candump -L log.

#include <algorithm>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "teleop/error.hpp"
#include "teleop/fieldbus/cia402_drive.hpp"
#include "teleop/fieldbus/simulated_cia402_drive.hpp"
#include "teleop/transport/can_emulated_bus.hpp"
#include "teleop/transport/can_log.hpp"

namespace teleop::fieldbus::test {

/// The simulated step: the drive answers within this (a real drive within tens of µs to a few ms).
inline constexpr std::uint64_t kSimStep_ns = 100'000;
/// The log's time stamps start at 2026-12-01 00:00:00 UTC (can-utils take a time of 0 s for "no time yet").
inline constexpr std::uint64_t kLogEpoch_ns = 1'796'083'200ULL * 1'000'000'000ULL;

/// The message of the teleop::Error `f` throws, or "(nothing thrown)".
inline std::string ThrownBy(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(nothing thrown)";
}

struct Cia402Rig {
  std::uint64_t now_ns = 0;
  transport::EmulatedCanBus bus;
  int host_node;
  int drive_node;
  int monitor_node;
  SimulatedCia402DriveConfig sim_config{};
  Cia402DriveConfig config{};
  std::unique_ptr<transport::CanPort> host_port;
  std::unique_ptr<transport::CanPort> drive_port;
  std::unique_ptr<transport::CanPort> monitor_port;
  std::unique_ptr<SimulatedCia402Drive> sim;
  std::unique_ptr<Cia402Drive> drive;
  std::unique_ptr<transport::CandumpLogWriter> log;
  std::uint64_t monitored = 0;
  bool capture = false;  ///< Keep every frame the monitor sees in `captured`.
  std::vector<proto::can::CanFrame> captured;
  std::vector<std::uint64_t> captured_ns;  ///< When the monitor read each captured frame (to kSimStep_ns).

  Cia402Rig()
      : bus(transport::EmulatedCanBusConfig{}, [this] { return now_ns; }),
        host_node(bus.AddNode()),
        drive_node(bus.AddNode()),
        monitor_node(bus.AddNode()) {
    config.sdo.timeout_ms = 5.0;
    config.sdo.backoff_initial_ms = 1.0;
  }

  /// Builds the ports, the simulated drive and the client from sim_config and config.
  void Build() {
    host_port = bus.MakePort(host_node, Cia402Drive::ReceiveOptions(config));
    drive_port = bus.MakePort(drive_node, SimulatedCia402Drive::ReceiveOptions(sim_config));
    monitor_port = bus.MakePort(monitor_node, transport::CanReceiveOptions::Everything());
    sim = std::make_unique<SimulatedCia402Drive>(sim_config, *drive_port);
    drive = std::make_unique<Cia402Drive>(config, *host_port, Clock());
  }

  Timebase Clock() {
    Timebase t;
    t.now_ns = [this] { return now_ns; };
    t.wait_ns = [this](std::uint64_t ns) { Advance(std::max<std::uint64_t>(ns, 1000)); };
    return t;
  }

  /// Moves the clock by `ns`, stepping the drive every kSimStep_ns and draining the monitor.
  void Advance(std::uint64_t ns) {
    const std::uint64_t end = now_ns + ns;
    while (now_ns < end) {
      now_ns = std::min(end, now_ns + kSimStep_ns);
      sim->Step(now_ns);
      DrainMonitor();
    }
  }

  void DrainMonitor() {
    proto::can::CanFrame f{};
    while (monitor_port->Read(f)) {
      ++monitored;
      if (capture) {
        captured.push_back(f);
        captured_ns.push_back(now_ns);
      }
      if (log) (void)log->Write(f, kLogEpoch_ns + now_ns);
    }
  }

  void BringUp() {
    drive->Configure();
    drive->Activate();
  }

  /// The setpoint in the configured mode's unit (N·m, rad/s or rad) through the client's named Write.
  Cia402Status Write(double setpoint) {
    switch (config.mode) {
      case Cia402Mode::kCyclicSynchronousPosition:
        return drive->WritePosition_rad(setpoint);
      case Cia402Mode::kCyclicSynchronousVelocity:
        return drive->WriteVelocity_rad_per_s(setpoint);
      case Cia402Mode::kCyclicSynchronousTorque:
        break;
    }
    return drive->WriteTorque_Nm(setpoint);
  }

  /// One control cycle: Write, one period of bus and drive time, Read.
  struct CycleResult {
    Cia402Status write = Cia402Status::kOk;
    Cia402Status read = Cia402Status::kOk;
    Cia402Reading reading{};
  };
  CycleResult Cycle(double setpoint) {
    CycleResult r;
    r.write = Write(setpoint);
    Advance(static_cast<std::uint64_t>(config.cycle_period_s * 1e9));
    r.read = drive->Read(r.reading);
    return r;
  }
};

}  // namespace teleop::fieldbus::test
