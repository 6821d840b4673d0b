// The real-rig config deploy/configs/cobot/cobot-master-fieldbus.yaml, loaded as teleop-master loads it, run
// against the simulated CiA 402 drive (the steering motor) and a simulated sensor node (wheel encoder, handle
// force, wheel brake) on the in-process emulated CAN bus, with the cart's rolling simulated around them: the same
// bytes a real rig puts on the bus. The operator pushes at 30° into the fixture plane y > 0.08 m; the cobot
// slides along it. Then each steering fault is injected while it tracks the wall, and the cobot must stop: the
// steering stays on the wall's tangent and the wheel brake engages.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numbers>
#include <string>

#include "device/cobot/cobot_fieldbus_device.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/simulated_cia402_drive.hpp"
#include "teleop/transport/can_emulated_bus.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::device::cobot {
namespace {

constexpr std::uint64_t kStep_ns = 100'000;  // the simulated drive's and the cart's integration step
constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kWall_m = 0.08;

std::string ConfigPath() { return std::string(TELEOP_SOURCE_DIR) + "/deploy/configs/cobot/cobot-master-fieldbus.yaml"; }

CobotBackendConfig LoadRigConfig() {
  const config::ProcessConfig process = config::LoadProcessConfig(ConfigPath());
  EXPECT_EQ(process.device.backend, "cobot");
  return process.device.Section<CobotBackendConfig>();
}

/// The rig around the device: bus, simulated drive and sensor node, and the cart they sit on.
struct FieldbusRig {
  std::uint64_t now_ns = 0;
  CobotBackendConfig config;
  transport::EmulatedCanBus bus;
  fieldbus::SimulatedCia402DriveConfig drive_config{};
  std::unique_ptr<transport::CanPort> host_drive_port, host_sensor_port, host_force_port, drive_port, node_port;
  std::unique_ptr<fieldbus::SimulatedCia402Drive> drive;
  std::unique_ptr<SimulatedCobotSensorNode> node;
  std::unique_ptr<UnicycleCobotFieldbusDevice> device;
  // The cart (no lateral slip: it rolls along the wheel's heading) and the operator.
  Vec2 position_m = Vec2::Zero();
  double speed_m_per_s = 0.0;
  double travel_m = 0.0;
  double push_direction_rad = 30.0 * kDeg;
  double integral_N = 0.0;
  Vec2 push_N = Vec2::Zero();
  double max_push_N = 30.0;
  bool force_sensor_broken = false;  ///< The node reports "no valid measurement" (NaN → 0x8000).
  Command command = Command::Force(DofVector::Zero(2));
  Reading reading{};

  explicit FieldbusRig(const CobotBackendConfig& c, double initial_heading_rad = 30.0 * kDeg)
      : config(c), bus(transport::EmulatedCanBusConfig{}, [this] { return now_ns; }) {
    const CobotFieldbusConfig& f = config.fieldbus;
    const double gear = f.steering.gear_ratio;
    // The drive's joint is the motor: the steering axis reflected through the gear.
    drive_config.node_id = f.steering.drive.node_id;
    drive_config.joint.inertia_kg_m2 = config.unicycle.plant.steering_inertia_kgm2 / (gear * gear);
    drive_config.joint.viscous_Nms_per_rad = config.unicycle.plant.steering_damping_Nms_per_rad / (gear * gear);
    drive_config.joint.coulomb_Nm = 1e-4;
    drive_config.rated_torque_mNm =
        static_cast<std::uint32_t>(std::lround(f.steering.drive.scaling.rated_torque_Nm * 1e3));
    drive_config.position_rad_per_count = f.steering.drive.scaling.position_rad_per_count;
    drive_config.velocity_rad_per_s_per_unit = f.steering.drive.scaling.velocity_rad_per_s_per_unit;
    const int host_a = bus.AddNode();
    const int host_b = bus.AddNode();
    const int host_c = bus.AddNode();
    const int drive_node = bus.AddNode();
    const int sensor_node = bus.AddNode();
    host_drive_port = bus.MakePort(host_a, fieldbus::Cia402Drive::ReceiveOptions(f.steering.drive));
    host_sensor_port = bus.MakePort(host_b, CobotSensorNode::ReceiveOptions(f.sensors));
    host_force_port = bus.MakePort(host_c, fieldbus::CanForceSensor::ReceiveOptions(f.sensors.ForceSensorConfig()));
    drive_port = bus.MakePort(drive_node, fieldbus::SimulatedCia402Drive::ReceiveOptions(drive_config));
    node_port = bus.MakePort(sensor_node, SimulatedCobotSensorNode::ReceiveOptions(f.sensors));
    drive = std::make_unique<fieldbus::SimulatedCia402Drive>(drive_config, *drive_port);
    node = std::make_unique<SimulatedCobotSensorNode>(f.sensors, *node_port);
    Advance(10'000'000);  // the drive boots
    drive->SetJointState(f.steering.drive.scaling.sign * (initial_heading_rad - f.steering_offset_rad) * gear, 0.0);
    position_m = config.initial.position_m;
    fieldbus::Timebase t;
    t.now_ns = [this] { return now_ns; };
    t.wait_ns = [this](std::uint64_t ns) { Advance(std::max<std::uint64_t>(ns, 1000)); };
    device =
        std::make_unique<UnicycleCobotFieldbusDevice>(config, *host_drive_port, *host_sensor_port, *host_force_port, t);
    device->Configure();
    device->Activate();
    command.constraint_count = 1;
    command.constraints[0].normal = DofVector::Zero(2);
    command.constraints[0].normal << 0.0, 1.0;
    command.constraints[0].offset_m = kWall_m;
  }

  double Heading() const {
    const CobotFieldbusConfig& f = config.fieldbus;
    return f.steering_offset_rad + f.steering.drive.scaling.sign * drive->position_rad() / f.steering.gear_ratio;
  }

  /// The bus, the drive and the cart over `ns`.
  void Advance(std::uint64_t ns) {
    const std::uint64_t end = now_ns + ns;
    while (now_ns < end) {
      const double h = static_cast<double>(std::min(kStep_ns, end - now_ns)) * 1e-9;
      now_ns += std::min(kStep_ns, end - now_ns);
      if (drive) drive->Step(now_ns);
      if (!node) continue;
      // The cart: m·u̇ = F·t − c·u − brake, rolling along the wheel's heading.
      const Vec2 t = UnitAt(Heading());
      const UnicyclePlantConfig& p = config.unicycle.plant;
      double f = push_N.dot(t) - p.rolling_damping_Ns_per_m * speed_m_per_s;
      if (node->brake_engaged()) {
        const double brake = p.brake_max_force_N;
        if (std::abs(speed_m_per_s) < brake * h / p.cart_mass_kg && std::abs(f) <= brake) {
          speed_m_per_s = 0.0;
          f = 0.0;
        } else {
          f -= brake * (speed_m_per_s >= 0.0 ? 1.0 : -1.0);
        }
      }
      speed_m_per_s += h * f / p.cart_mass_kg;
      position_m += h * speed_m_per_s * t;
      travel_m += h * speed_m_per_s;
      node->Set(travel_m, force_sensor_broken ? Vec2(std::nan(""), std::nan("")) : push_N);
      node->Step();
    }
  }

  /// One 1 ms cycle as teleop-master runs it: Read, then Write (or SetSafe on a fault), Update; then the bus time.
  void Cycle() {
    // The operator holds 0.2 m/s towards push_direction with a PI on the force (as the simulated operator).
    const double error = 0.2 - std::abs(speed_m_per_s);
    integral_N = std::clamp(integral_N + 300.0 * error * 1e-3, 0.0, max_push_N);
    push_N = std::clamp(100.0 * error + integral_N, 0.5, max_push_N) * UnitAt(push_direction_rad);
    device->Read(reading);
    if (reading.faults != kFaultNone) {
      device->SetSafe();
    } else {
      device->Write(command);
    }
    device->Update(1e-3);
    Advance(1'000'000);
  }

  /// Runs until the cobot tracks the wall and has slid along it for a while.
  void SlideAlongTheWall() {
    for (int k = 0; k < 2500; ++k) Cycle();
  }
};

TEST(CobotFieldbusRig, ConfigSelectsTheFieldbusDriver) {
  const CobotBackendConfig c = LoadRigConfig();
  EXPECT_EQ(c.rig, CobotBackendConfig::Rig::kFieldbus);
  EXPECT_EQ(c.fieldbus.can.interface_name, "can0");
  EXPECT_EQ(c.fieldbus.steering.drive.node_id, 5);
  EXPECT_EQ(c.fieldbus.sensors.node_id, 10);
  EXPECT_TRUE(c.fieldbus.sensors.has_brake);
  EXPECT_DOUBLE_EQ(c.fieldbus.steering.gear_ratio, 10.0);
  // The registry builds the fieldbus device from it (its ports open at Configure, not here).
  const std::unique_ptr<Device> device = MakeDevice(DeviceConfig::Of("cobot", 2, c));
  EXPECT_NE(dynamic_cast<UnicycleCobotFieldbusDevice*>(device.get()), nullptr);
  EXPECT_TRUE(device->capabilities().has_brake);
  EXPECT_EQ(device->capabilities().rendering, Rendering::kSteeredConstraints);
}

TEST(CobotFieldbusRig, TracksTheFixtureWallThroughTheBus) {
  FieldbusRig rig(LoadRigConfig());
  double max_y = 0.0;
  double max_odometry_error = 0.0;
  for (int k = 0; k < 3000; ++k) {
    rig.Cycle();
    ASSERT_EQ(rig.reading.faults, kFaultNone) << "cycle " << k;
    max_y = std::max(max_y, rig.position_m.y());
    const Vec2 measured(rig.reading.position_m[0], rig.reading.position_m[1]);
    max_odometry_error = std::max(max_odometry_error, (measured - rig.position_m).norm());
  }
  std::printf("fieldbus rig: max penetration %.2f mm, x %.3f m, heading %.2f deg, odometry error %.3f mm\n",
              (max_y - kWall_m) * 1e3, rig.position_m.x(), rig.Heading() / kDeg, max_odometry_error * 1e3);
  EXPECT_LT(max_y, kWall_m + 0.006);          // held at the plane (overlay on): the simulated rig's 5 mm class
  EXPECT_GT(rig.position_m.x(), 0.35);        // sliding along it
  EXPECT_NEAR(rig.Heading(), 0.0, 3 * kDeg);  // on the wall's tangent
  EXPECT_EQ(rig.device->controller().mode(), WallMode::kTracking);
  EXPECT_LT(max_odometry_error, 0.002);                        // wheel encoder + steering angle → position
  EXPECT_NEAR(rig.reading.force_N[0], rig.push_N.x(), 0.011);  // the handle force through the node's TPDO
  EXPECT_FALSE(rig.node->brake_engaged());
}

enum class Injected { kHeartbeat, kSilentDrive, kDriveFault, kSensorNodeLost, kForceInvalid };

void ExpectTheCobotStops(Injected what, SteeringFault steering, SensorFault sensor, std::uint32_t bits) {
  FieldbusRig rig(LoadRigConfig());
  rig.SlideAlongTheWall();
  ASSERT_EQ(rig.device->controller().mode(), WallMode::kTracking);
  const double tangent_error_before = std::abs(rig.Heading());
  switch (what) {
    case Injected::kHeartbeat:
      rig.drive->SetHeartbeatMuted(true);
      break;
    case Injected::kSilentDrive:
      rig.drive->SetSilent(true);
      break;
    case Injected::kDriveFault:
      rig.drive->InjectFault(0x2310);
      break;
    case Injected::kSensorNodeLost:
      rig.node->SetSilent(true);
      break;
    case Injected::kForceInvalid:
      rig.force_sensor_broken = true;
      break;
  }
  int cycles = 0;
  while (rig.reading.faults == kFaultNone && cycles < 1000) {
    rig.Cycle();
    ++cycles;
  }
  EXPECT_EQ(rig.device->steering_fault(), steering);
  EXPECT_EQ(rig.device->sensor_fault(), sensor);
  EXPECT_EQ(rig.reading.faults & bits, bits);
  EXPECT_TRUE(rig.device->locked());
  std::printf("fault '%s'/'%s' after %d cycles: %s\n", ToString(rig.device->steering_fault()),
              ToString(rig.device->sensor_fault()), cycles, rig.device->FaultText().c_str());
  // The operator is told which node and what failed (Device::FaultText).
  const std::string text = rig.device->FaultText();
  if (steering != SteeringFault::kNone) {
    EXPECT_EQ(
        text.rfind("the steering drive (node " + std::to_string(rig.config.fieldbus.steering.drive.node_id) + ") ", 0),
        0u)
        << text;
  }
  if (sensor != SensorFault::kNone) {
    EXPECT_NE(text.find("the sensor node (node " + std::to_string(rig.config.fieldbus.sensors.node_id) + ") "),
              std::string::npos)
        << text;
  }
  if (steering == SteeringFault::kDriveLost) {
    EXPECT_NE(text.find("stopped answering"), std::string::npos) << text;
  }
  if (steering == SteeringFault::kHeartbeatLost) {
    EXPECT_NE(text.find("heartbeat"), std::string::npos) << text;
  }
  if (sensor == SensorFault::kLost) {
    EXPECT_NE(text.find("stopped sending"), std::string::npos) << text;
  }
  // The operator keeps pushing at 30° into the wall for 1.5 s.
  double max_tangent_error = 0.0;
  double max_y = 0.0;
  for (int k = 0; k < 1500; ++k) {
    rig.Cycle();
    max_tangent_error = std::max(max_tangent_error, std::abs(rig.Heading()));
    max_y = std::max(max_y, rig.position_m.y());
  }
  EXPECT_TRUE(rig.node->brake_engaged());
  EXPECT_TRUE(rig.device->brake_engaged());
  std::printf("  then: heading off the tangent %.2f deg (before %.2f), max penetration %.2f mm, speed %.4f m/s\n",
              max_tangent_error / kDeg, tangent_error_before / kDeg, (max_y - kWall_m) * 1e3, rig.speed_m_per_s);
  EXPECT_LT(max_tangent_error, tangent_error_before + 2 * kDeg);  // the steering stays on the wall's tangent
  EXPECT_LT(max_y, kWall_m + 0.006);
  EXPECT_NEAR(rig.speed_m_per_s, 0.0, 1e-3);  // braked to a stop against the 30 N push
  EXPECT_NE(rig.reading.faults, kFaultNone);  // latched
}

TEST(CobotFieldbusRig, HeartbeatTimeoutStopsTheCobot) {
  ExpectTheCobotStops(Injected::kHeartbeat, SteeringFault::kHeartbeatLost, SensorFault::kNone, kFaultCommunication);
}

TEST(CobotFieldbusRig, LostDriveStopsTheCobot) {
  ExpectTheCobotStops(Injected::kSilentDrive, SteeringFault::kDriveLost, SensorFault::kNone, kFaultCommunication);
}

TEST(CobotFieldbusRig, DriveFaultStopsTheCobot) {
  ExpectTheCobotStops(Injected::kDriveFault, SteeringFault::kDriveFault, SensorFault::kNone, kFaultDriver);
}

TEST(CobotFieldbusRig, LostSensorNodeStopsTheCobot) {
  // The steering drive still obeys: the steering is held on its heading (Γ = −K₂ω) and the brake engages — but
  // the brake output is on the lost node: it engages only if the node still listens (here it does, it only stopped
  // sending).
  ExpectTheCobotStops(Injected::kSensorNodeLost, SteeringFault::kNone, SensorFault::kLost, kFaultCommunication);
}

TEST(CobotFieldbusRig, InvalidHandleForceStopsTheCobot) {
  // The force sensor's "no valid measurement" (overload, error: 0x8000 on the bus, NaN through CanForceSensor).
  ExpectTheCobotStops(Injected::kForceInvalid, SteeringFault::kNone, SensorFault::kForceInvalid, kFaultNonFiniteSensor);
}

TEST(CobotFieldbusRig, EncoderJumpHoldsTheSteeringAndBrakes) {
  FieldbusRig rig(LoadRigConfig());
  rig.SlideAlongTheWall();
  // A counting error: the drive's position actual jumps by 0.6 rad at the steering axis (6 rad at the motor) while
  // the wheel does not move. Injected as a knock of the joint, then the hold must keep the encoder where it is.
  rig.drive->SetJointState(rig.drive->position_rad() + 0.6 * rig.config.fieldbus.steering.gear_ratio,
                           rig.drive->velocity_rad_per_s());
  rig.Cycle();
  rig.Cycle();
  EXPECT_EQ(rig.device->steering_fault(), SteeringFault::kEncoderJump);
  EXPECT_EQ(rig.reading.faults & kFaultDriver, kFaultDriver);
  const double held_at = rig.Heading();
  for (int k = 0; k < 1500; ++k) rig.Cycle();
  EXPECT_NEAR(rig.Heading(), held_at, 0.05);  // held where the jump left it
  EXPECT_TRUE(rig.node->brake_engaged());
  EXPECT_NEAR(rig.speed_m_per_s, 0.0, 1e-3);
}

TEST(CobotFieldbusRig, WithoutABrakeTheLockedSteeringKeepsTheCartOnTheTangent) {
  CobotBackendConfig c = LoadRigConfig();
  c.unicycle.plant.brake_max_force_N = 0.0;
  c.fieldbus.sensors.has_brake = false;
  FieldbusRig rig(c);
  rig.SlideAlongTheWall();
  const double tangent_error_before = std::abs(rig.Heading());
  rig.drive->SetHeartbeatMuted(true);
  double max_tangent_error = 0.0;
  double max_y = 0.0;
  for (int k = 0; k < 1500; ++k) {
    rig.Cycle();
    max_tangent_error = std::max(max_tangent_error, std::abs(rig.Heading()));
    max_y = std::max(max_y, rig.position_m.y());
  }
  EXPECT_EQ(rig.device->steering_fault(), SteeringFault::kHeartbeatLost);
  EXPECT_FALSE(rig.node->brake_engaged());
  // No torque reaches the steering and nothing else turns it: the cart rolls on along the wall, not into it.
  EXPECT_LT(max_tangent_error, tangent_error_before + 2 * kDeg);
  EXPECT_LT(max_y, kWall_m + 0.006);
  EXPECT_GT(rig.speed_m_per_s, 0.1);
}

TEST(CobotFieldbusRig, CycleDoesNotAllocate) {
  FieldbusRig rig(LoadRigConfig());
  for (int k = 0; k < 100; ++k) rig.Cycle();
  std::uint64_t allocations = 0;
  for (int k = 0; k < 500; ++k) {
    {
      test::AllocationCounter counter;  // the device's cycle only, not the simulated bus and drive
      rig.device->Read(rig.reading);
      rig.device->Write(rig.command);
      rig.device->Update(1e-3);
      if (k == 400) rig.device->SetSafe();  // the safe cycle too
      allocations += counter.count();
    }
    rig.Advance(1'000'000);
  }
  EXPECT_EQ(allocations, 0u);
}

TEST(CobotFieldbusRig, ConfigErrorsNameTheKey) {
  const auto read = [](const std::string& yaml) {
    static const std::string file = "rig.yaml";
    const YAML::Node node = YAML::Load(yaml);
    const config::Field field(node, "device.cobot", &file);
    return FindDevice("cobot")->read(&field, SectionContext{Role::kMaster, 2});
  };
  const std::string ok_bus = "fieldbus: {can: {interface: can0}, steering: {node_id: 5}, sensors: {node_id: 10}}";
  EXPECT_NO_THROW(read("{rig: fieldbus, " + ok_bus + "}"));
  const auto message = [&](const std::string& yaml) {
    try {
      read(yaml);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("{rig: fieldbus}").find("fieldbus"), std::string::npos);
  EXPECT_NE(message("{rig: robot}").find("simulated or fieldbus"), std::string::npos);
  EXPECT_NE(message("{" + ok_bus + "}").find("only for rig: fieldbus"), std::string::npos);
  // The client has mode 9; the rig refuses it for its own reason (τ is the host loop's), not the client's.
  const std::string velocity = message(
      "{rig: fieldbus, fieldbus: {can: {interface: can0}, steering: {node_id: 5, mode: velocity}, "
      "sensors: {node_id: 10}}}");
  EXPECT_NE(velocity.find("not supported by the cobot rig"), std::string::npos) << velocity;
  EXPECT_NE(velocity.find("steering_time_constant_s"), std::string::npos) << velocity;
  EXPECT_NE(message("{rig: fieldbus, fieldbus: {can: {interface: can0}, steering: {node_id: 5}, "
                    "sensors: {node_id: 5}}}")
                .find("is taken"),
            std::string::npos);
  EXPECT_NE(message("{rig: fieldbus, fieldbus: {can: {interface: can0}, steering: {node_id: 200}, "
                    "sensors: {node_id: 10}}}")
                .find("node_id"),
            std::string::npos);
  EXPECT_NE(message("{rig: fieldbus, fieldbus: {can: {medium: emulated, interface: can0}, steering: {node_id: 5}, "
                    "sensors: {node_id: 10}}}")
                .find("only for medium socketcan"),
            std::string::npos);
  EXPECT_NE(message("{rig: fieldbus, fieldbus: {can: {interface: can0}, steering: {node_id: 5}, "
                    "sensors: {node_id: 10, source: drive}}}")
                .find("not supported"),
            std::string::npos);
  EXPECT_NE(message("{rig: fieldbus, kind: bicycle, " + ok_bus + "}").find("unicycle"), std::string::npos);
  EXPECT_NE(message("{rig: fieldbus, operator: {speed_m_per_s: 0.1}, " + ok_bus + "}").find("only for rig"),
            std::string::npos);
  // The error names the file, line and key.
  EXPECT_NE(message("{rig: fieldbus, fieldbus: {can: {interface: can0}, steering: {node_id: 5, gear_ratio: -1}, "
                    "sensors: {node_id: 10}}}")
                .find("rig.yaml:1:"),
            std::string::npos);
}

}  // namespace
}  // namespace teleop::device::cobot
