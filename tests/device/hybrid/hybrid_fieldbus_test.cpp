// The real-rig driver against what the real rig speaks: two simulated CiA 402 drives on the emulated CAN bus (manual
// clock) and the pymodbus server as the brake amplifier + force sensor (tests/fieldbus/modbus_server.py).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <sstream>
#include <string>
#include <thread>

#include "device/hybrid/hybrid_fieldbus_device.hpp"
#include "modbus_test_server.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/simulated_can_force_sensor.hpp"
#include "teleop/fieldbus/simulated_cia402_drive.hpp"
#include "teleop/transport/can_emulated_bus.hpp"
#include "test_utilities/sync_gate.hpp"

namespace teleop::device::hybrid {
namespace {

using fieldbus::Cia402Drive;
using fieldbus::ModbusPoint;
using fieldbus::ModbusTable;
using fieldbus::ModbusValueType;
using fieldbus::SimulatedCia402Drive;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr std::uint64_t kStep_ns = 100'000;

ModbusPoint Point(const char* name, ModbusTable table, int address, double scale, double safe = 0.0) {
  ModbusPoint p;
  p.name = name;
  p.table = table;
  p.address = address;
  p.type = ModbusValueType::kInt16;
  p.scale = scale;
  p.safe_value = safe;
  return p;
}

using test::SyncGate;  // drive 1's host port as the device sees it (test_utilities/sync_gate.hpp)

struct Rig {
  std::uint64_t now_ns = 0;
  transport::EmulatedCanBus bus{transport::EmulatedCanBusConfig{}, [this] { return now_ns; }};
  test::ModbusTestServer server = test::ModbusTestServer::Tcp();
  HybridFieldbusConfig config;
  std::array<std::unique_ptr<transport::CanPort>, 2> host_ports;
  std::array<std::unique_ptr<transport::CanPort>, 2> drive_ports;
  std::array<std::unique_ptr<SimulatedCia402Drive>, 2> sims;
  std::unique_ptr<transport::CanPort> monitor;  // every frame, like candump
  std::unique_ptr<transport::CanPort> sensor_host_port;
  std::unique_ptr<transport::CanPort> sensor_node_port;
  std::unique_ptr<fieldbus::SimulatedCanForceSensor> sensor;
  std::unique_ptr<SyncGate> gate;                // drive 1's host port as the device sees it
  std::unique_ptr<HybridFieldbusDevice> device;  // last: destroyed first (its Deactivate steps the rig)

  explicit Rig(bool can_sensor = false, bool clutch_pedal = false) {
    // Handle at (0, 200 mm) when both drives read 0: θ1 = 30°, θ2 = 150°.
    config.joint_offset_rad = {30.0 * kDeg, 150.0 * kDeg};
    for (int i = 0; i < 2; ++i) {
      auto& d = config.drives[static_cast<std::size_t>(i)];
      d.node_id = static_cast<std::uint8_t>(i + 1);
      d.produce_sync = false;  // the device produces the bus's SYNC
      d.sdo.timeout_ms = 5.0;
      d.sdo.backoff_initial_ms = 1.0;
      d.max_torque_Nm = 4.44;
      d.scaling.rated_torque_Nm = 1.0;
    }
    auto& a = config.amplifier;
    a.tcp.port = server.modbus_port();
    a.poll_period_ms = 5.0;
    a.response_timeout_ms = 300.0;  // generous on a loaded machine
    a.stale_after_ms = 2000.0;
    a.command_timeout_ms = 0.0;
    a.outputs = {Point("brake_1_Nm", ModbusTable::kHoldingRegister, 0, 0.001, 4.0),
                 Point("brake_2_Nm", ModbusTable::kHoldingRegister, 1, 0.001, 4.0)};
    a.inputs = {Point("force_x_N", ModbusTable::kInputRegister, 0, 0.01),
                Point("force_y_N", ModbusTable::kInputRegister, 1, 0.01)};
    if (clutch_pedal) a.inputs.push_back(Point("clutch", ModbusTable::kDiscreteInput, 0, 1.0));
    for (int i = 0; i < 2; ++i) {
      const auto k = static_cast<std::size_t>(i);
      fieldbus::SimulatedCia402DriveConfig s;
      s.node_id = static_cast<std::uint8_t>(i + 1);
      s.joint.inertia_kg_m2 = 2e-3;  // at the drive shaft (the joint's 0.02 kg·m² less the pulleys, roughly)
      const int host = bus.AddNode();
      const int node = bus.AddNode();
      host_ports[k] = bus.MakePort(host, Cia402Drive::ReceiveOptions(config.drives[k]));
      drive_ports[k] = bus.MakePort(node, SimulatedCia402Drive::ReceiveOptions(s));
      sims[k] = std::make_unique<SimulatedCia402Drive>(s, *drive_ports[k]);
    }
    monitor = bus.MakePort(bus.AddNode(), transport::CanReceiveOptions::Everything());
    if (can_sensor) {
      config.force_sensor = ForceSensorBus::kCan;
      config.amplifier.inputs.clear();
      sensor_host_port = bus.MakePort(bus.AddNode(), fieldbus::CanForceSensor::ReceiveOptions(config.can_force_sensor));
      sensor_node_port = bus.MakePort(bus.AddNode(), fieldbus::SimulatedCanForceSensor::ReceiveOptions());
      sensor = std::make_unique<fieldbus::SimulatedCanForceSensor>(config.can_force_sensor, *sensor_node_port);
    }
    fieldbus::Timebase clock;
    clock.now_ns = [this] { return now_ns; };
    clock.wait_ns = [this](std::uint64_t ns) { Advance(std::max<std::uint64_t>(ns, 1000)); };
    gate = std::make_unique<SyncGate>(*host_ports[0]);
    device = std::make_unique<HybridFieldbusDevice>(config, *gate, *host_ports[1], clock, sensor_host_port.get());
  }

  void Advance(std::uint64_t ns) {
    const std::uint64_t end = now_ns + ns;
    while (now_ns < end) {
      now_ns = std::min(end, now_ns + kStep_ns);
      for (auto& s : sims) s->Step(now_ns);
      if (sensor) {
        bus.Run();
        sensor->Step();
      }
    }
  }

  void BringUp() {
    device->Configure();
    device->Activate();
  }

  /// One 1 ms control cycle as the node runs it: Exchange, Read, Write, Update, then bus and drive time.
  Reading Cycle(const Eigen::Vector2d& force_N) {
    Reading r;
    device->Exchange();
    device->Read(r);
    DofVector f = DofVector::Zero(2);
    f << force_N.x(), force_N.y();
    device->Write(Command::Force(f));
    device->Update(1e-3);
    Advance(1'000'000);
    return r;
  }

  /// The amplifier's brake registers (N·m at the shaft), as the server holds them.
  Eigen::Vector2d BrakeRegisters() {
    std::istringstream in(server.Control("get hr 0 2"));
    double a = 0.0;
    double b = 0.0;
    in >> a >> b;
    return {a * 0.001, b * 0.001};
  }

  /// Real time for the Modbus thread, with the CAN side cycling.
  template <typename Pred>
  bool CycleUntil(Pred done, double timeout_s, const Eigen::Vector2d& force_N) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      (void)Cycle(force_N);
      if (done()) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return false;
  }
};

// Bring-up, then the cycle: position from the drives' encoders through the kinematics, force from the amplifier's
// inputs, motor torque to the drives (CST) and brake torque to the amplifier through the allocation.
TEST(HybridFieldbusDevice, RendersThroughDrivesAndAmplifier) {
  Rig rig;
  rig.BringUp();
  ASSERT_EQ(rig.server.Control("set ir 0 0 1500"), "ok");  // the operator pushes +15 N along y...
  // ...on the joints too: τ_h = Jᵀ·(0, 15 N) at θ = (30°, 150°), at the drive shafts (÷ 5).
  const double tau_h = 0.2 * std::cos(30.0 * kDeg) * 15.0 / 5.0;
  rig.sims[0]->SetExternalTorque(tau_h);
  rig.sims[1]->SetExternalTorque(-tau_h);
  // Wait for the sensor value to arrive (real time), with no force command.
  ASSERT_TRUE(rig.CycleUntil(
      [&] {
        Reading r;
        rig.device->Read(r);
        return std::abs(r.force_N(1) - 15.0) < 1e-9;
      },
      3.0, Eigen::Vector2d::Zero()));
  Reading r = rig.Cycle(Eigen::Vector2d::Zero());
  EXPECT_EQ(r.faults, kFaultNone);
  EXPECT_NEAR(r.position_m.x(), 0.0, 1e-3);  // the handle near the origin (0, 200 mm), pushed along +y
  EXPECT_GT(r.velocity_m_per_s(1), 0.0);
  // A wall-like force against the operator's push (and the motion it causes): the brakes engage, the motors render
  // the desired force minus the brakes' estimate.
  for (int k = 0; k < 20; ++k) r = rig.Cycle({0.0, -10.0});
  const AllocationOutput previous = rig.device->last_allocation();
  r = rig.Cycle({0.0, -10.0});
  EXPECT_TRUE(rig.device->last_allocation().brake_engaged[0] && rig.device->last_allocation().brake_engaged[1]);
  // A synchronous RPDO takes effect on the next SYNC, which the next cycle's Exchange() sends: after a cycle, both
  // drives hold the previous cycle's torque, together. Per-mille quantisation of 1 N·m rated torque, × 5 at the
  // joint.
  const Eigen::Vector2d commanded{rig.sims[0]->commanded_torque_Nm(), rig.sims[1]->commanded_torque_Nm()};
  EXPECT_NEAR(commanded(0) * 5.0, previous.motor_joint_Nm(0), 0.003);
  EXPECT_NEAR(commanded(1) * 5.0, previous.motor_joint_Nm(1), 0.003);
  EXPECT_LT(std::abs(previous.motor_joint_Nm(0)), std::abs(previous.desired_joint_Nm(0)));  // the brakes share
  const Eigen::Vector2d want = rig.device->last_allocation().brake_shaft_Nm;
  EXPECT_GT(want.minCoeff(), 0.1);
  ASSERT_TRUE(rig.CycleUntil(
      [&] {
        return (rig.BrakeRegisters() - rig.device->last_allocation().brake_shaft_Nm).cwiseAbs().maxCoeff() < 0.0015;
      },
      3.0, {0.0, -10.0}));
  EXPECT_FALSE(rig.device->latched_safe());
}

// One SYNC per cycle for the bus, after both drives' RPDOs (golden frame order), and both drives apply a new
// torque on the same SYNC: a step of the command reaches both drives in the same cycle.
TEST(HybridFieldbusDevice, OneSyncPerCycleAfterBothRpdosBothDrivesApplyTogether) {
  Rig rig;
  rig.BringUp();
  for (int k = 0; k < 5; ++k) (void)rig.Cycle(Eigen::Vector2d::Zero());
  proto::can::CanFrame f;
  while (rig.monitor->Read(f)) {
  }
  for (int k = 0; k < 3; ++k) (void)rig.Cycle(Eigen::Vector2d::Zero());
  std::string order;
  while (rig.monitor->Read(f)) {
    if (f.error || (f.id != 0x080 && f.id != 0x201 && f.id != 0x202)) continue;
    char id[8];
    std::snprintf(id, sizeof id, "%03X ", static_cast<unsigned>(f.id));
    order += id;
  }
  EXPECT_EQ(order, "080 201 202 080 201 202 080 201 202 ");
  EXPECT_GE(rig.device->sync().counters().sent, 8u);  // priming SYNCs in Activate(), then one per cycle
  EXPECT_EQ(rig.device->drive(0).counters().syncs_sent + rig.device->drive(1).counters().syncs_sent, 0u);
  // The SYNC is the exchange's (Device::Exchange), not Read's: reading again sends nothing.
  const std::uint64_t sent = rig.device->sync().counters().sent;
  Reading again;
  rig.device->Read(again);
  rig.device->Read(again);
  EXPECT_EQ(rig.device->sync().counters().sent, sent);
  EXPECT_FALSE(rig.monitor->Read(f)) << "Read put a frame on the bus";
  // A force step along x: both joints get a non-zero torque. Each cycle: before the step, both drives hold zero;
  // one cycle after it, both hold the new torque (never one without the other).
  bool both_changed = false;
  for (int k = 0; k < 4 && !both_changed; ++k) {
    (void)rig.Cycle({20.0, 0.0});
    const bool c0 = std::abs(rig.sims[0]->commanded_torque_Nm()) > 0.01;
    const bool c1 = std::abs(rig.sims[1]->commanded_torque_Nm()) > 0.01;
    EXPECT_EQ(c0, c1) << "cycle " << k << ": one drive applied the step a SYNC before the other";
    both_changed = c0 && c1;
  }
  EXPECT_TRUE(both_changed);
}

// A drive that leaves Operation Enabled: the device latches its safe state, reports the drive, sends zero torque to
// both drives and engages both brakes.
TEST(HybridFieldbusDevice, ARefusedSyncIsNamedAsTheSyncNotAsADrive) {
  Rig rig;
  rig.BringUp();
  for (int k = 0; k < 20; ++k) (void)rig.Cycle({5.0, 5.0});
  ASSERT_FALSE(rig.device->latched_safe());
  rig.gate->refuse_sync = true;
  const Reading r = rig.Cycle({5.0, 5.0});
  ASSERT_TRUE(rig.device->latched_safe());
  EXPECT_EQ(rig.device->fault_source(), RigFaultSource::kSync);
  EXPECT_STREQ(ToString(rig.device->fault_source()), "SYNC");
  EXPECT_EQ(rig.device->FaultText(), "the bus refused the cycle's SYNC (bus-off or a full transmit queue)");
  EXPECT_NE(r.faults & kFaultCommunication, 0u);
  EXPECT_EQ(rig.device->drive(0).counters().write_failures, 0u);  // drive 1's own frames all went out
}

TEST(HybridFieldbusDevice, DriveLeavingOperationEnabledEngagesTheSafeState) {
  Rig rig;
  rig.BringUp();
  for (int k = 0; k < 20; ++k) (void)rig.Cycle({5.0, 5.0});
  ASSERT_FALSE(rig.device->latched_safe());
  rig.sims[1]->ForceDisable();
  Reading r;
  for (int k = 0; k < 10 && !rig.device->latched_safe(); ++k) r = rig.Cycle({5.0, 5.0});
  ASSERT_TRUE(rig.device->latched_safe());
  EXPECT_EQ(rig.device->fault_source(), RigFaultSource::kDrive2);
  EXPECT_EQ(rig.device->fault_status(), fieldbus::Cia402Status::kNotEnabled);
  EXPECT_EQ(rig.device->FaultText(), "drive 2 (node " + std::to_string(rig.device->drive(1).config().node_id) +
                                         "): the drive left Operation Enabled (an external disable, STO, or a quick "
                                         "stop)");
  r = rig.Cycle({5.0, 5.0});
  EXPECT_NE(r.faults & kFaultDriver, 0u);
  for (int k = 0; k < 5; ++k) (void)rig.Cycle({5.0, 5.0});
  EXPECT_NEAR(rig.sims[0]->commanded_torque_Nm(), 0.0, 1e-9);
  ASSERT_TRUE(rig.CycleUntil([&] { return rig.BrakeRegisters().minCoeff() > 3.999; }, 3.0, {5.0, 5.0}));
}

// An amplifier that stops answering: the device latches its safe state within the configured bound (one response
// timeout) and the drives get zero torque; when it answers again it is commanded to full braking.
TEST(HybridFieldbusDevice, SilentAmplifierEngagesTheSafeState) {
  Rig rig;
  rig.BringUp();
  for (int k = 0; k < 20; ++k) (void)rig.Cycle({5.0, 0.0});
  ASSERT_FALSE(rig.device->latched_safe());
  ASSERT_EQ(rig.server.Control("mode stop"), "ok");
  ASSERT_TRUE(rig.CycleUntil([&] { return rig.device->latched_safe(); }, 5.0, {5.0, 0.0}));
  EXPECT_EQ(rig.device->fault_source(), RigFaultSource::kAmplifier);
  EXPECT_EQ(rig.device->FaultText().rfind("the brake amplifier (Modbus): ", 0), 0u) << rig.device->FaultText();
  const Reading r = rig.Cycle({5.0, 0.0});
  EXPECT_NE(r.faults & kFaultCommunication, 0u);
  (void)rig.Cycle({5.0, 0.0});
  EXPECT_NEAR(rig.sims[0]->commanded_torque_Nm(), 0.0, 1e-9);
  EXPECT_NEAR(rig.sims[1]->commanded_torque_Nm(), 0.0, 1e-9);
  ASSERT_EQ(rig.server.Control("mode normal"), "ok");
  ASSERT_TRUE(rig.CycleUntil([&] { return rig.BrakeRegisters().minCoeff() > 3.999; }, 5.0, {5.0, 0.0}));
  EXPECT_TRUE(rig.device->latched_safe());  // latched until Activate() again
}

// The operator's clutch pedal on a discrete input of the amplifier (the register map's input `clutch`): the reading
// follows it, pressed and released, with no fault; a rig without that input never reports it.
TEST(HybridFieldbusDevice, ClutchPedalOnADiscreteInputIsTheReadingsClutch) {
  Rig rig(false, true);
  rig.BringUp();
  Reading r = rig.Cycle(Eigen::Vector2d::Zero());
  EXPECT_FALSE(r.clutch_pressed);
  ASSERT_EQ(rig.server.Control("set di 0 1"), "ok");
  ASSERT_TRUE(rig.CycleUntil(
      [&] {
        rig.device->Read(r);
        return r.clutch_pressed;
      },
      3.0, Eigen::Vector2d::Zero()));
  EXPECT_EQ(r.faults, kFaultNone);
  ASSERT_EQ(rig.server.Control("set di 0 0"), "ok");
  ASSERT_TRUE(rig.CycleUntil(
      [&] {
        rig.device->Read(r);
        return !r.clutch_pressed;
      },
      3.0, Eigen::Vector2d::Zero()));
  EXPECT_FALSE(rig.device->latched_safe());

  Rig plain;
  plain.BringUp();
  ASSERT_EQ(plain.server.Control("set di 0 1"), "ok");
  ASSERT_EQ(plain.server.Control("set ir 0 0 1500"), "ok");
  ASSERT_TRUE(plain.CycleUntil(  // a poll after both were set has arrived
      [&] {
        plain.device->Read(r);
        return std::abs(r.force_N(1) - 15.0) < 1e-9;
      },
      3.0, Eigen::Vector2d::Zero()));
  EXPECT_FALSE(r.clutch_pressed);
}

// The handle force sensor on CAN (answering each SYNC of the device): its force in the reading; silent, it goes stale
// and latches the safe state, named.
TEST(HybridFieldbusDevice, CanForceSensorIsReadAndItsSilenceEngagesTheSafeState) {
  Rig rig(/*can_sensor=*/true);
  const std::array<double, 2> push{2.5, -7.25};
  rig.sensor->SetForce(push);
  rig.BringUp();
  Reading r;
  for (int k = 0; k < 3; ++k) r = rig.Cycle(Eigen::Vector2d::Zero());
  EXPECT_EQ(r.faults, kFaultNone);
  EXPECT_DOUBLE_EQ(r.force_N(0), 2.5);
  EXPECT_DOUBLE_EQ(r.force_N(1), -7.25);
  ASSERT_NE(rig.device->force_sensor(), nullptr);
  EXPECT_GE(rig.device->force_sensor()->counters().frames, 3u);
  rig.sensor->SetSilent(true);
  int cycles = 0;
  while (!rig.device->latched_safe() && cycles < 100) {
    r = rig.Cycle(Eigen::Vector2d::Zero());
    ++cycles;
  }
  ASSERT_TRUE(rig.device->latched_safe());
  EXPECT_EQ(rig.device->fault_source(), RigFaultSource::kForceSensor);
  EXPECT_NE(rig.device->FaultText().find("no frame for its stale_after_ms (10 ms)"), std::string::npos)
      << rig.device->FaultText();
  EXPECT_GE(cycles, 9);  // stale_after_ms = 10 ms of 1 ms cycles, not before
  r = rig.Cycle(Eigen::Vector2d::Zero());
  EXPECT_NE(r.faults & kFaultCommunication, 0u);
  (void)rig.Cycle(Eigen::Vector2d::Zero());
  EXPECT_NEAR(rig.sims[0]->commanded_torque_Nm(), 0.0, 1e-9);
  EXPECT_NEAR(rig.sims[1]->commanded_torque_Nm(), 0.0, 1e-9);
}

TEST(HybridFieldbusDevice, RegisterMapWithoutBrakeOutputsIsRejected) {
  HybridFieldbusConfig c;
  c.drives[1].node_id = 2;
  c.amplifier.inputs = {Point("fx", ModbusTable::kInputRegister, 0, 0.01),
                        Point("fy", ModbusTable::kInputRegister, 1, 0.01)};
  EXPECT_THROW(c.Validate(), Error);
}

}  // namespace
}  // namespace teleop::device::hybrid
