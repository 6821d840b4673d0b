// The arm backend on MIT-mode motors (common/src/device/arm/mit_joint_bus.hpp, docs/arms.md "MIT motors"): the
// 7-joint arm of deploy/robots/arm_7dof_mit.urdf on simulated DM-J motors (simulated_mit_arm.hpp), every command
// and reply crossing the in-process emulated CAN FD bus as the motors' bytes. It follows and stops at a plane; a
// motor that stops answering, one that reports over-temperature and a host that dies each end with every motor
// disabled and the fault named; a rig that does not fit its bus is refused saying what fits; the cycle does not
// allocate.

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "arm_device.hpp"
#include "arm_section.hpp"
#include "mit_joint_bus.hpp"
#include "simulated_mit_arm.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/mit_motor_models.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::device::arm {
namespace {

namespace mit = proto::can::mit;

const std::string kRobots = TELEOP_ROBOTS_DIR;
constexpr double kPeriod_s = 0.001;
constexpr const char* kModels[7] = {"DM-J8009", "DM-J8009", "DM-J4340", "DM-J4340", "DM-J4310", "DM-J4310", "DM-J4310"};

std::vector<double> Start() { return {0, 0.6, 0, -1.4, 0, 0.9, 0}; }

ArmSection MitSection() {
  ArmSection s;
  s.chain.urdf_file = kRobots + "/arm_7dof_mit.urdf";
  s.chain.base_link = "base";
  s.chain.tool_link = "tool";
  s.device.min_manipulability = 1e-3;
  s.device.torque.hold_orientation = true;
  s.device.torque.orientation_stiffness_Nm_per_rad = 10.0;
  s.device.torque.orientation_damping_Nms_per_rad = 0.3;
  s.device.torque.posture_stiffness_Nm_per_rad = 3.0;
  s.device.torque.posture_damping_Nms_per_rad = 0.3;
  s.posture_q_rad = Start();
  s.initial_q_rad = Start();
  s.simulation.viscous_Nms_per_rad = 0.2;
  s.simulation.coulomb_Nm = 0.02;
  s.mit_actuators = true;
  const auto models = fieldbus::ReadMitMotorModels(fieldbus::DefaultMitMotorModelsPath());
  MitJointBusConfig& m = s.mit;
  m.simulated = true;
  m.fd = true;
  for (int i = 0; i < 7; ++i) {
    MitJointConfig j;
    j.model = kModels[i];
    j.motor = models.at(j.model);
    j.esc_id = static_cast<std::uint32_t>(1 + i);
    j.master_id = static_cast<std::uint32_t>(0x11 + i);
    m.joints.push_back(j);
  }
  // Mounting: motor 3 turned against the joint's axis, motor 1 zeroed 0.1 rad off the URDF's zero.
  m.joints[2].sign = -1.0;
  m.joints[0].offset_rad = 0.1;
  return s;
}

/// The arm, its bus and the plant behind it, configured and active.
struct MitArmRig {
  explicit MitArmRig(const ArmSection& s = MitSection()) {
    auto model = std::make_unique<ArmModel>(BuildArmChain(s.chain), s.gravity_B());
    ArmDeviceConfig device = s.device;
    JointVector posture(7);
    for (int i = 0; i < 7; ++i) posture[i] = s.posture_q_rad[static_cast<std::size_t>(i)];
    device.torque.posture_q = posture;
    auto joint_bus = MakeMitJointBus(s);
    bus = joint_bus.get();
    plant = dynamic_cast<SimulatedMitArm*>(bus->plant());
    arm = std::make_unique<ArmDevice>(std::move(model), std::move(joint_bus), device);
    arm->Configure();
    arm->Activate();
    arm->Read(r);
    origin = r.position_m;
  }
  /// One cycle with the force F (N, base frame) commanded.
  void Cycle(const Eigen::Vector3d& force_N) {
    arm->Read(r);
    if (r.faults == kFaultNone) {
      DofVector f(3);
      f << force_N[0], force_N[1], force_N[2];
      arm->Write(Command::Force(f));
    } else {
      arm->SetSafe();
    }
    arm->Update(kPeriod_s);
  }
  bool AllDisabled() {
    for (int i = 0; i < 7; ++i) {
      if (plant->motor(i).enabled()) return false;
    }
    return true;
  }
  Eigen::Vector3d x() const {
    return {r.position_m[0] - origin[0], r.position_m[1] - origin[1], r.position_m[2] - origin[2]};
  }

  MitJointBus* bus = nullptr;
  SimulatedMitArm* plant = nullptr;
  std::unique_ptr<ArmDevice> arm;
  Reading r;
  DofVector origin;
};

// A coupling spring to a target that moves down 5 cm in 1 s, and a plane fixture 3 cm below the start: the arm on
// simulated MIT motors tracks the target in free space and comes to rest on the plane.
TEST(MitArm, FollowsAndStopsAtThePlane) {
  MitArmRig rig;
  ASSERT_EQ(rig.r.faults, kFaultNone) << rig.arm->ActuatorFaultText();
  constexpr double kCoupling_N_per_m = 300.0, kDamping_Ns_per_m = 5.0, kFixture_N_per_m = 2000.0, kPlane_m = -0.03;
  double max_free_error_m = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const double t = k * kPeriod_s;
    const Eigen::Vector3d target(0, 0, -0.05 * std::min(1.0, t));
    const Eigen::Vector3d x = rig.x();
    const Eigen::Vector3d v(rig.r.velocity_m_per_s[0], rig.r.velocity_m_per_s[1], rig.r.velocity_m_per_s[2]);
    Eigen::Vector3d f = kCoupling_N_per_m * (target - x) - kDamping_Ns_per_m * v;
    if (x.z() < kPlane_m) f.z() += kFixture_N_per_m * (kPlane_m - x.z());
    rig.Cycle(f);
    ASSERT_EQ(rig.r.faults, kFaultNone) << "cycle " << k << ": " << rig.arm->ActuatorFaultText();
    if (t > 0.2 && t < 0.55) max_free_error_m = std::max(max_free_error_m, (target - x).norm());
  }
  const double z = rig.x().z();
  std::printf("tracking error in free space (0.2..0.55 s) at most %.2f mm; at rest %.2f mm below the plane\n",
              max_free_error_m * 1e3, (kPlane_m - z) * 1e3);
  // Free space (target above the plane): the lag of a 300 N/m spring against 5 N·s/m at 5 cm/s, about 1 mm.
  EXPECT_LT(max_free_error_m, 0.005);
  // At rest on the plane: the coupling's pull (2 cm short of the target) balanced by the fixture, 2.6 mm deep.
  EXPECT_LT(z, kPlane_m);
  EXPECT_GT(z, kPlane_m - 0.004);
  EXPECT_LT(std::abs(rig.r.velocity_m_per_s[2]), 0.005);
  // The motors carried it: every one enabled, every command answered (a command every cycle but the first, which
  // enables them).
  for (int i = 0; i < 7; ++i) {
    EXPECT_TRUE(rig.plant->motor(i).enabled()) << i;
    EXPECT_EQ(rig.plant->motor(i).commands_received(), 1999u) << i;
    EXPECT_EQ(rig.bus->bus().state(static_cast<std::size_t>(i)).missing, 0u) << i;
  }
  // Motor 3 turns against its joint: its command's torque has the opposite sign of the joint's.
  EXPECT_LT(rig.bus->command(2).torque_Nm * rig.arm->torque().terms().applied_Nm[2], 0.0);
}

TEST(MitArm, AMotorThatStopsAnsweringIsAFaultNamedAndEveryMotorIsDisabled) {
  MitArmRig rig;
  for (int k = 0; k < 100; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  ASSERT_EQ(rig.r.faults, kFaultNone);
  rig.plant->motor(3).SetSilent(true);
  int k = 0;
  for (; k < 50 && rig.r.faults == kFaultNone; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_EQ(k, MitJointBusConfig{}.missing_limit + 2);  // the limit in a row, then the Read that sees it
  EXPECT_EQ(rig.r.faults, kFaultCommunication);
  EXPECT_EQ(rig.arm->arm_faults(), kArmFaultActuator | kArmFaultNoReply);
  EXPECT_NE(rig.arm->ActuatorFaultText().find("joint 4 'joint4': the motor stopped answering"), std::string::npos)
      << rig.arm->ActuatorFaultText();
  for (int j = 0; j < 10; ++j) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_TRUE(rig.AllDisabled());
  EXPECT_TRUE(rig.bus->faulted());
}

TEST(MitArm, OverTemperatureWarnsThenFaultsByName) {
  MitArmRig rig;
  for (int k = 0; k < 50; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  rig.plant->motor(5).SetTemperature(75.0);  // above the warning (70 °C), below the fault (100 °C)
  for (int k = 0; k < 5; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_EQ(rig.r.faults, kFaultNone);
  EXPECT_EQ(rig.arm->arm_warnings(), kArmWarningTemperature);
  EXPECT_FALSE(rig.AllDisabled());
  rig.plant->motor(5).InjectFault(mit::MotorStatus::kCoilOverTemperature);
  for (int k = 0; k < 5; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_EQ(rig.r.faults, kFaultOvertemperature);
  EXPECT_EQ(rig.arm->arm_faults(), kArmFaultActuator | kArmFaultOverTemperature);
  EXPECT_EQ(rig.arm->ActuatorFaultText(), "joint 6 'joint6': coil over-temperature (code 0xC)");
  EXPECT_EQ(rig.arm->FaultText(), rig.arm->ActuatorFaultText()) << "what the event log's device-fault line says";
  EXPECT_TRUE(rig.AllDisabled());
  // Activation is refused while the motor reports it, with its name.
  rig.arm->Deactivate();
  try {
    rig.arm->Activate();
    ADD_FAILURE() << "activated with a motor at coil over-temperature";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("joint 6 'joint6' (DM-J4310) (esc_id 0x6) reports coil over-temperature"),
              std::string::npos)
        << e.what();
  }
}

// The host stops exchanging (it died); the motors' own CAN timeout (mit.motor_timeout_ms, register 9, written at
// Configure) disables them; a host that comes back reads "communication lost". Without the timeout they would
// stay enabled.
TEST(MitArm, AHostThatDiesLeavesEveryMotorDisabledByItsOwnTimeout) {
  for (const double timeout_ms : {50.0, 0.0}) {
    ArmSection s = MitSection();
    s.mit.motor_timeout_ms = timeout_ms;
    MitArmRig rig(s);
    for (int k = 0; k < 100; ++k) rig.Cycle(Eigen::Vector3d::Zero());
    for (int k = 0; k < 60; ++k) rig.plant->Advance(kPeriod_s);  // 60 ms with no frame from the host
    if (timeout_ms == 0.0) {
      for (int i = 0; i < 7; ++i) EXPECT_TRUE(rig.plant->motor(i).enabled()) << i;
      continue;
    }
    for (int i = 0; i < 7; ++i) {
      EXPECT_EQ(rig.plant->motor(i).status(), static_cast<std::uint8_t>(mit::MotorStatus::kCommunicationLost)) << i;
    }
    rig.Cycle(Eigen::Vector3d::Zero());
    rig.Cycle(Eigen::Vector3d::Zero());
    EXPECT_EQ(rig.r.faults, kFaultCommunication);
    EXPECT_EQ(rig.arm->ActuatorFaultText(), "joint 1 'joint1': communication lost (code 0xD)");
    EXPECT_TRUE(rig.AllDisabled());
  }
}

// The loop's first cycle may come long after Activate (the peer, the start-up check's sweep): the motors' own
// timeout (50 ms) must count from the loop's first exchange, not from the enable at Activate. Activate leaves them
// disabled (verified enabled, then disabled again); the first exchange enables them, the commands follow. Before,
// the 200 ms here left every motor in communication lost (0xD) at the first cycle.
TEST(MitArm, TheMotorTimeoutCountsFromTheFirstCommandNotFromActivate) {
  MitArmRig rig;
  for (int k = 0; k < 200; ++k) rig.plant->Advance(kPeriod_s);  // 200 ms before the loop's first cycle
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(rig.plant->motor(i).status(), static_cast<std::uint8_t>(mit::MotorStatus::kDisabled)) << i;
  }
  for (int k = 0; k < 100; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_EQ(rig.r.faults, kFaultNone) << rig.arm->ActuatorFaultText();
  for (int i = 0; i < 7; ++i) {
    EXPECT_TRUE(rig.plant->motor(i).enabled()) << i;
    EXPECT_EQ(rig.plant->motor(i).commands_received(), 99u) << i;  // the first cycle enables
  }
  // And the timeout still guards the cycle: 60 ms without a frame after the last command disables every motor.
  for (int k = 0; k < 60; ++k) rig.plant->Advance(kPeriod_s);
  EXPECT_TRUE(rig.AllDisabled());
}

// A motor that answers but never shows enabled (its driver stage or firmware refuses the enable): Activate refuses it
// by name; one that stops enabling after Activate (the loop's first exchange re-enables every motor) is a fault of
// its joint after missing_limit exchanges, named, and every motor is disabled: the arm does not run on six joints.
TEST(MitArm, AMotorThatNeverEnablesIsAFaultNamedAndTheArmDoesNotRun) {
  {
    ArmSection s = MitSection();
    auto model = std::make_unique<ArmModel>(BuildArmChain(s.chain), s.gravity_B());
    ArmDeviceConfig device = s.device;
    JointVector posture(7);
    for (int i = 0; i < 7; ++i) posture[i] = s.posture_q_rad[static_cast<std::size_t>(i)];
    device.torque.posture_q = posture;
    auto joint_bus = MakeMitJointBus(s);
    auto* plant = dynamic_cast<SimulatedMitArm*>(joint_bus->plant());
    ArmDevice arm(std::move(model), std::move(joint_bus), device);
    arm.Configure();
    plant->motor(3).SetIgnoreEnable(true);
    try {
      arm.Activate();
      ADD_FAILURE() << "activated with a motor that never enables";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(
                    "joint 4 'joint4' (DM-J4340) (esc_id 0x4) did not enable: it reports disabled (code 0x0)"),
                std::string::npos)
          << e.what();
    }
    for (int i = 0; i < 7; ++i) EXPECT_FALSE(plant->motor(i).enabled()) << i;
  }
  MitArmRig rig;
  rig.plant->motor(3).SetIgnoreEnable(true);  // after Activate: the loop's enable is the one it refuses
  int k = 0;
  for (; k < 50 && rig.r.faults == kFaultNone; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_EQ(k, MitJointBusConfig{}.missing_limit + 2);  // the enable's exchange, the limit, the Read that sees it
  EXPECT_EQ(rig.r.faults, kFaultDriver);
  EXPECT_EQ(rig.arm->arm_faults(), kArmFaultActuator);
  const std::string text = rig.arm->ActuatorFaultText();
  std::printf("%s\n", text.c_str());
  EXPECT_EQ(text.rfind("joint 4 'joint4': the motor never enabled", 0), 0u) << text;
  EXPECT_NE(text.find("(code 0x103)"), std::string::npos) << text;
  for (int j = 0; j < 5; ++j) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_TRUE(rig.AllDisabled());
  EXPECT_TRUE(rig.bus->faulted());
  EXPECT_EQ(rig.plant->motor(3).torque_Nm(), 0.0);
}

TEST(MitArm, TheCycleDoesNotAllocate) {
  MitArmRig rig;
  for (int k = 0; k < 10; ++k) rig.Cycle(Eigen::Vector3d(1, 2, -3));
  test::AllocationCounter counter;
  for (int k = 0; k < 100; ++k) rig.Cycle(Eigen::Vector3d(1, 2, -3));
  rig.arm->SetSafe();
  rig.arm->Update(kPeriod_s);
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_EQ(rig.r.faults, kFaultNone);
}

// control: pd: each motor runs its own PD (the joint's Kp, Kd sent as Kp/gear², Kd/gear²) to the joint's last reading
// at zero velocity, with the arm's torque as the feed-forward; the arm still holds its weight.
TEST(MitArm, PdControlSendsTheJointGainsThroughTheGear) {
  ArmSection s = MitSection();
  s.mit.control = MitControl::kPd;
  for (MitJointConfig& j : s.mit.joints) j.kd_Nms_per_rad = 0.4;
  s.mit.joints[6].gear_ratio = 2.0;  // joint 7 behind a 2:1 reduction
  s.mit.joints[6].kp_Nm_per_rad = 8.0;
  MitArmRig rig(s);
  for (int k = 0; k < 300; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_EQ(rig.r.faults, kFaultNone) << rig.arm->ActuatorFaultText();
  EXPECT_DOUBLE_EQ(rig.bus->command(0).kd_Nm_s_per_rad, 0.4);
  EXPECT_DOUBLE_EQ(rig.bus->command(6).kd_Nm_s_per_rad, 0.1);
  EXPECT_DOUBLE_EQ(rig.bus->command(6).kp_Nm_per_rad, 2.0);
  EXPECT_DOUBLE_EQ(rig.bus->command(6).velocity_rad_per_s, 0.0);
  // The target is the joint's reading, on the motor's side of the reduction.
  JointSample j7;
  rig.bus->joint(6).Read(j7);
  EXPECT_NEAR(rig.bus->command(6).position_rad, 2.0 * j7.position, 1e-12);
  EXPECT_NEAR(rig.plant->motor(6).position_rad(), 2.0 * rig.plant->arm().q()[6], 1e-9);
  // Held still: within a few steps of the 16-bit position of the start.
  JointVector start(7);
  for (int i = 0; i < 7; ++i) start[i] = Start()[static_cast<std::size_t>(i)];
  EXPECT_LT((rig.plant->arm().q() - start).cwiseAbs().maxCoeff(), 5e-3);
}

// ---- the YAML section -----------------------------------------------------------------------------------------

std::any ReadSection(const std::string& yaml) {
  static const std::string file = kRobots + "/config.yaml";
  const YAML::Node node = YAML::Load(yaml);
  const config::Field field(node, "device.arm", &file);
  return FindDevice("arm")->read(&field, SectionContext{Role::kSlave, 3});
}

std::string MitYaml(const std::string& bus) {
  std::string joints;
  for (int i = 0; i < 7; ++i) {
    joints += "    - {model: " + std::string(kModels[i]) + ", esc_id: " + std::to_string(i + 1) +
              ", master_id: " + std::to_string(0x11 + i) + "}\n";
  }
  return "urdf: arm_7dof_mit.urdf\nbase_link: base\ntool_link: tool\nactuators: mit\n"
         "simulation: {initial_q_rad: [0, 0.6, 0, -1.4, 0, 0.9, 0]}\nmit:\n" +
         bus + "  joints:\n" + joints;
}

TEST(MitArm, ARigThatDoesNotFitItsBusIsRefusedSayingWhatFits) {
  const std::string classic = "  bus: can\n  can: {medium: socketcan, interface: can0}\n  fd: false\n";
  try {
    (void)ReadSection(MitYaml(classic));
    ADD_FAILURE() << "7 motors at 1 kHz accepted on one classic 1 Mbit/s bus";
  } catch (const Error& e) {
    const std::string m = e.what();
    std::printf("%s\n", m.c_str());
    EXPECT_NE(m.find("7 MIT motors at 1000 Hz"), std::string::npos) << m;
    EXPECT_NE(m.find("classic CAN bus (1000 kbit/s) to 1.89"), std::string::npos) << m;
    EXPECT_NE(m.find("CAN FD with a 5 Mbit/s data phase (load 0.79)"), std::string::npos) << m;
    EXPECT_NE(m.find("2 motors per bus at 1000 Hz (4 buses for 7 joints)"), std::string::npos) << m;
  }
  EXPECT_NO_THROW((void)ReadSection(MitYaml(classic + "  rate_hz: 400\n")));  // 0.76 of the bus
  const std::string fd = "  bus: can\n  can: {medium: socketcan, interface: can0}\n  fd: true\n";
  const auto section = std::any_cast<ArmSection>(ReadSection(MitYaml(fd)));
  EXPECT_TRUE(section.mit_actuators);
  EXPECT_EQ(section.mit.joints[6].model, "DM-J4310");
  EXPECT_DOUBLE_EQ(section.mit.joints[0].motor.peak_torque_Nm, 40.0);
  EXPECT_EQ(section.mit.can.interface_name, "can0");
}

// The mit section's keys with a value are the key table's (arm_keys.hpp): absent, each reads as MitJointBusConfig's
// default; given, as written; a wrong word or a value out of range is refused by the key's name.
TEST(MitArm, TheMitKeysDefaultsAreTheConfigsAndGivenValuesAreRead) {
  const MitJointBusConfig code{};
  const MitJointBusConfig absent = std::any_cast<ArmSection>(ReadSection(MitYaml("  bus: simulated\n"))).mit;
  EXPECT_TRUE(absent.simulated);
  EXPECT_EQ(absent.fd, code.fd);
  EXPECT_EQ(absent.nominal_bitrate_bit_per_s, code.nominal_bitrate_bit_per_s);
  EXPECT_EQ(absent.max_bus_load, code.max_bus_load);
  EXPECT_EQ(absent.control, code.control);
  EXPECT_EQ(absent.missing_limit, code.missing_limit);
  EXPECT_EQ(absent.motor_timeout_ms, code.motor_timeout_ms);
  EXPECT_EQ(absent.temperature_fault_C, code.temperature_fault_C);
  const MitJointBusConfig given =
      std::any_cast<ArmSection>(ReadSection(MitYaml("  bus: simulated\n  control: pd\n  missing_limit: 3\n"
                                                    "  reply_wait_us: 250\n  temperature_warning_C: 60\n")))
          .mit;
  EXPECT_EQ(given.control, MitControl::kPd);
  EXPECT_EQ(given.missing_limit, 3);
  EXPECT_EQ(given.reply_wait_us, 250.0);
  EXPECT_EQ(given.temperature_warning_C, 60.0);
  const auto error = [](const std::string& bus) -> std::string {
    try {
      (void)ReadSection(MitYaml(bus));
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error("  bus: ethercat\n").find("'device.arm.mit.bus': must be simulated or can, got 'ethercat'"),
            std::string::npos);
  EXPECT_NE(error("  bus: simulated\n  control: current\n").find("'device.arm.mit.control'"), std::string::npos);
  EXPECT_NE(error("  bus: simulated\n  missing_limit: 0\n").find("'device.arm.mit.missing_limit'"), std::string::npos);
  EXPECT_NE(error("  bus: simulated\n  warp: 1\n").find("mit.warp"), std::string::npos);
}

TEST(MitArm, TheSimulatedYamlRigBuildsAndRuns) {
  DeviceConfig config;
  config.backend = "arm";
  config.dof = 3;
  config.section = ReadSection(MitYaml("  bus: simulated\n"));
  const std::unique_ptr<Device> device = MakeDevice(config);
  device->Configure();
  device->Activate();
  Reading r;
  for (int k = 0; k < 200; ++k) {
    device->Read(r);
    device->Write(Command::Force(DofVector::Zero(3)));
    device->Update(kPeriod_s);
  }
  EXPECT_EQ(r.faults, kFaultNone);
  device->Deactivate();
}

}  // namespace
}  // namespace teleop::device::arm
