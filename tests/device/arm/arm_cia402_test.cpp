// The arm backend on CiA 402 drives (common/src/device/arm/cia402_joint_bus.hpp, docs/arms.md "CiA 402 joints"):
// the 7-joint arm of deploy/robots/arm_7dof.urdf on simulated CiA 402 drives in cyclic synchronous torque mode
// (simulated_cia402_arm.hpp) on four in-process emulated classic CAN buses, every SDO, SYNC, RPDO and TPDO crossing
// them as the drives' bytes. It follows and stops at a plane; a drive that faults and one that stops answering each
// end with every drive in quick stop and the joint named; the cycle's frames are the golden ones; a rig that does
// not fit its buses is refused saying what fits; the cycle does not allocate.

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "arm_device.hpp"
#include "arm_section.hpp"
#include "cia402_joint_bus.hpp"
#include "simulated_cia402_arm.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "teleop/proto/can/can_frame.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::device::arm {
namespace {

const std::string kRobots = TELEOP_ROBOTS_DIR;
constexpr double kPeriod_s = 0.001;
// The URDF's efforts (N·m) as each drive's 0x6072, rated torque half of it (a drive's peak is commonly 2-3x rated).
constexpr double kEffort_Nm[7] = {176, 176, 110, 110, 110, 40, 40};
// Two drives per bus at 1 kHz (CheckCia402BusLoad): four buses.
constexpr int kBus[7] = {0, 0, 1, 1, 2, 2, 3};

std::vector<double> Start() { return {0, 0.6, 0, -1.4, 0, 0.9, 0}; }

ArmSection Cia402Section() {
  ArmSection s;
  s.chain.urdf_file = kRobots + "/arm_7dof.urdf";
  s.chain.base_link = "base";
  s.chain.tool_link = "tool";
  s.device.min_manipulability = 1e-3;
  s.device.torque.hold_orientation = true;
  s.device.torque.orientation_stiffness_Nm_per_rad = 30.0;
  s.device.torque.orientation_damping_Nms_per_rad = 1.0;
  s.device.torque.posture_stiffness_Nm_per_rad = 5.0;
  s.device.torque.posture_damping_Nms_per_rad = 1.0;
  s.posture_q_rad = Start();
  s.initial_q_rad = Start();
  s.simulation.viscous_Nms_per_rad = 0.5;
  s.simulation.coulomb_Nm = 0.05;
  s.cia402_actuators = true;
  Cia402JointBusConfig& c = s.cia402;
  c.simulated = true;
  for (int i = 0; i < 7; ++i) {
    Cia402JointConfig j;
    j.bus = kBus[i];
    j.node_id = static_cast<std::uint8_t>(1 + i);
    j.rated_torque_Nm = 0.5 * kEffort_Nm[i];
    j.max_torque_Nm = kEffort_Nm[i];
    j.position_rad_per_count = 2.0 * M_PI / (1 << 19);  // 19 bits per turn
    j.velocity_rad_per_s_per_unit = 1e-4;
    c.joints.push_back(j);
  }
  // Mounting: drive 3 turned against the joint's axis, drive 1 zeroed 0.1 rad off the URDF's zero, drive 7 behind
  // a 2:1 reduction (its rated and maximum torque on its own side).
  c.joints[2].sign = -1.0;
  c.joints[0].offset_rad = 0.1;
  c.joints[6].gear_ratio = 2.0;
  c.joints[6].rated_torque_Nm /= 2.0;
  c.joints[6].max_torque_Nm /= 2.0;
  return s;
}

/// The arm, its bus and the plant behind it, configured and active.
struct Cia402ArmRig {
  explicit Cia402ArmRig(const ArmSection& s = Cia402Section()) {
    auto model = std::make_unique<ArmModel>(BuildArmChain(s.chain), s.gravity_B());
    ArmDeviceConfig device = s.device;
    JointVector posture(7);
    for (int i = 0; i < 7; ++i) posture[i] = s.posture_q_rad[static_cast<std::size_t>(i)];
    device.torque.posture_q = posture;
    auto joint_bus = MakeCia402JointBus(s);
    bus = joint_bus.get();
    plant = dynamic_cast<SimulatedCia402Arm*>(bus->plant());
    arm = std::make_unique<ArmDevice>(std::move(model), std::move(joint_bus), device);
    arm->Configure();
    arm->Activate();
    arm->Read(r);  // the readings of the activation (no exchange: every Exchange is followed by an Update)
    origin = r.position_m;
  }
  /// One cycle as the node runs it: the bus exchange, Read, Write (or the safe state), Update.
  void Cycle(const Eigen::Vector3d& force_N) {
    arm->Exchange();
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
  bool NoneEnabled() {
    for (int i = 0; i < 7; ++i) {
      if (plant->drive(i).drive_state() == fieldbus::cia402::DriveState::kOperationEnabled) return false;
    }
    return true;
  }
  Eigen::Vector3d x() const {
    return {r.position_m[0] - origin[0], r.position_m[1] - origin[1], r.position_m[2] - origin[2]};
  }

  Cia402JointBus* bus = nullptr;
  SimulatedCia402Arm* plant = nullptr;
  std::unique_ptr<ArmDevice> arm;
  Reading r;
  DofVector origin;
};

// A coupling spring to a target that moves down 5 cm in 1 s, and a plane fixture 3 cm below the start: the arm on
// simulated CiA 402 drives tracks the target in free space and comes to rest on the plane.
TEST(Cia402Arm, FollowsAndStopsAtThePlane) {
  Cia402ArmRig rig;
  ASSERT_EQ(rig.r.faults, kFaultNone) << rig.arm->ActuatorFaultText();
  constexpr double kCoupling_N_per_m = 300.0, kDamping_Ns_per_m = 10.0, kFixture_N_per_m = 2000.0, kPlane_m = -0.03;
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
  EXPECT_LT(max_free_error_m, 0.01);
  // At rest on the plane: the coupling's pull (2 cm short of the target) balanced by the fixture, 2.6 mm deep.
  EXPECT_LT(z, kPlane_m);
  EXPECT_GT(z, kPlane_m - 0.004);
  EXPECT_LT(std::abs(rig.r.velocity_m_per_s[2]), 0.005);
  // The drives carried it: every one in Operation Enabled, one SYNC per cycle on each bus, every RPDO taken.
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(rig.plant->drive(i).drive_state(), fieldbus::cia402::DriveState::kOperationEnabled) << i;
    EXPECT_GE(rig.plant->drive(i).counters().rpdos, 2000u) << i;
    EXPECT_GE(rig.plant->drive(i).counters().syncs, 2000u) << i;
    EXPECT_EQ(rig.bus->drive(i).counters().tpdos_rejected, 0u) << i;
  }
  // Drive 3 turns against its joint: the torque it applies has the opposite sign of the joint's.
  EXPECT_LT(rig.plant->drive(2).applied_torque_Nm() * rig.arm->torque().terms().applied_Nm[2], 0.0);
  // Drive 7 is behind 2:1: its shaft turns twice the joint's angle.
  EXPECT_NEAR(rig.plant->drive(6).position_rad(), 2.0 * rig.plant->arm().q()[6], 1e-9);
}

// The cycle's frames on bus 3 (drive 7 alone, node 7) as they cross the wire, in order: the SYNC, the TPDOs it
// triggers, the RPDO for the next SYNC. 0x6071 is in per mille of the rated torque 0x6076 (CiA 402): a joint
// torque of 2.5 N·m behind 2:1 is 1.25 N·m at the drive, 125 ‰ of its 10 N·m rated torque = 0x007D.
TEST(Cia402Arm, TheCycleFramesAreTheGoldenOnes) {
  Cia402ArmRig rig;
  transport::EmulatedCanBus& bus = rig.plant->bus(3);
  auto sniffer = bus.MakePort(bus.AddNode());
  rig.Cycle(Eigen::Vector3d::Zero());
  rig.bus->joint(6).WriteTorque(2.5);
  rig.arm->Update(kPeriod_s);  // the RPDO of the torque written
  std::vector<std::string> frames;
  proto::can::CanFrame f{};
  while (sniffer->Read(f)) {
    char text[64];
    int n = std::snprintf(text, sizeof text, "%03X#", static_cast<unsigned>(f.id));
    for (std::size_t b = 0; b < f.len; ++b)
      n += std::snprintf(text + n, sizeof text - static_cast<std::size_t>(n), "%02X", f.data[b]);
    frames.emplace_back(text);
  }
  // First the host's heartbeat with which Activate ends (CiA 301: 0x700 + node 127, state 05 Operational), still
  // on the wire when the cycle starts. The cycle's frames: the SYNC (no data); the RPDO queued beside it leaves right
  // after it (applied at the next SYNC); TPDO1 (statusword: Operation Enabled, remote, following the command;
  // position) and TPDO2 (velocity, torque actual) answer the SYNC; the last is the RPDO of the torque written:
  // controlword 0x000F (enable operation), target torque 0x007D.
  std::string all;
  for (const std::string& frame : frames) all += frame + " ";
  ASSERT_GE(frames.size(), 6u) << all;
  EXPECT_EQ(frames[0], "77F#05") << all;
  EXPECT_EQ(frames[1], "080#") << all;
  EXPECT_EQ(frames[2].substr(0, 4), "207#") << all;
  EXPECT_EQ(frames[3].substr(0, 8), "187#3712") << all;
  EXPECT_EQ(frames[4].substr(0, 4), "287#") << all;
  EXPECT_EQ(frames.back(), "207#0F007D00") << all;
  EXPECT_EQ(std::count(frames.begin(), frames.end(), "080#"), 1) << all;
}

TEST(Cia402Arm, ADriveThatFaultsIsNamedWithItsErrorCodeAndEveryDriveStops) {
  Cia402ArmRig rig;
  for (int k = 0; k < 100; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  ASSERT_EQ(rig.r.faults, kFaultNone);
  rig.plant->drive(4).InjectFault(0x2310);  // CiA 402: continuous over-current
  int k = 0;
  for (; k < 20 && rig.r.faults == kFaultNone; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_LE(k, 3);
  EXPECT_EQ(rig.r.faults, kFaultDriver);
  EXPECT_EQ(rig.arm->arm_faults(), kArmFaultActuator);
  const std::string text = rig.arm->ActuatorFaultText();
  std::printf("%s\n", text.c_str());
  EXPECT_NE(text.find("joint 5 'joint5': "), std::string::npos) << text;
  EXPECT_NE(text.find("(code 0x2310)"), std::string::npos) << text;
  for (int j = 0; j < 200; ++j) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_TRUE(rig.bus->faulted());
  EXPECT_TRUE(rig.NoneEnabled());
  // Deactivate takes every drive out of the cycle: torque 0, Shutdown, pre-operational.
  rig.arm->Deactivate();
  rig.plant->timebase().wait_ns(1'000'000);  // the last NMT frame crosses the bus
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(rig.plant->drive(i).nmt_state(), fieldbus::canopen::NmtState::kPreOperational) << i;
  }
}

TEST(Cia402Arm, ADriveThatStopsAnsweringIsNamedAndEveryDriveStops) {
  Cia402ArmRig rig;
  for (int k = 0; k < 100; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  ASSERT_EQ(rig.r.faults, kFaultNone);
  rig.plant->drive(3).SetSilent(true);
  int k = 0;
  for (; k < 50 && rig.r.faults == kFaultNone; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  // stale_after_ms (10) after its last TPDO.
  EXPECT_GE(k, 9);
  EXPECT_LE(k, 13);
  EXPECT_EQ(rig.r.faults, kFaultCommunication);
  EXPECT_EQ(rig.arm->arm_faults(), kArmFaultActuator | kArmFaultNoReply);
  EXPECT_EQ(rig.arm->ActuatorFaultText(),
            "joint 4 'joint4': the drive stopped answering (no TPDO for cia402.stale_after_ms) (code 0x10002)");
  for (int j = 0; j < 200; ++j) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_TRUE(rig.bus->faulted());
  for (int i = 0; i < 7; ++i) {
    if (i == 3) continue;  // the silent one hears the quick stop too, but nobody can see it
    EXPECT_NE(rig.plant->drive(i).drive_state(), fieldbus::cia402::DriveState::kOperationEnabled) << i;
  }
}

// The loop's first cycle may come long after Activate (the peer, the start-up check): the readings of the activation
// count until the first SYNC has answered, and the drives do not fault meanwhile, as long as the first cycle comes
// within the drives' consumer time of the host's heartbeat (Activate ends with a heartbeat on every bus). Later, the
// drives' consumers fire: a host that activated and never ran its loop is a dead host.
TEST(Cia402Arm, ALateFirstCycleIsNotAFault) {
  Cia402ArmRig rig;
  rig.plant->timebase().wait_ns(200'000'000);  // 200 ms between Activate and the first cycle, the arm held
  for (int k = 0; k < 20; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_EQ(rig.r.faults, kFaultNone) << rig.arm->ActuatorFaultText();
  Cia402ArmRig late;
  late.plant->timebase().wait_ns(350'000'000);  // beyond the 300 ms consumer time
  for (int k = 0; k < 5; ++k) late.Cycle(Eigen::Vector3d::Zero());
  EXPECT_EQ(late.r.faults, kFaultCommunication);
  EXPECT_NE(late.arm->ActuatorFaultText().find("(code 0x8130)"), std::string::npos) << late.arm->ActuatorFaultText();
}

// Each drive consumes the host's heartbeat while the arm is active (0x1016:01 = host node 127 << 16 | 300 ms, CiA
// 301), one heartbeat per bus every 100 ms from the cycle; Deactivate switches the consumers off, so a host that
// stops cleanly leaves no drive to fault.
TEST(Cia402Arm, EveryDriveConsumesTheHostHeartbeatWhileActive) {
  Cia402ArmRig rig;
  const Cia402JointBusConfig defaults;
  ASSERT_EQ(defaults.drive_consumer_timeout_ms, 300.0);
  for (int i = 0; i < 7; ++i) EXPECT_EQ(rig.plant->drive(i).consumer_heartbeat(), (127u << 16) | 300u) << i;
  std::uint64_t sent[4];
  for (int b = 0; b < 4; ++b) sent[b] = rig.bus->host_heartbeat(b)->counters().sent;
  for (int k = 0; k < 500; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_EQ(rig.r.faults, kFaultNone) << rig.arm->ActuatorFaultText();
  for (int b = 0; b < 4; ++b) {
    const std::uint64_t in_loop = rig.bus->host_heartbeat(b)->counters().sent - sent[b];
    EXPECT_GE(in_loop, 4u) << b;  // 500 cycles of 1 ms, one heartbeat each 100 ms after Activate's
    EXPECT_LE(in_loop, 5u) << b;
  }
  rig.arm->Deactivate();
  for (int i = 0; i < 7; ++i) EXPECT_EQ(rig.plant->drive(i).consumer_heartbeat(), 0u) << i;
  rig.plant->timebase().wait_ns(1'000'000'000);  // 1 s without a host heartbeat
  for (int i = 0; i < 7; ++i) {
    EXPECT_NE(rig.plant->drive(i).drive_state(), fieldbus::cia402::DriveState::kFault) << i;
    EXPECT_EQ(rig.plant->drive(i).counters().host_heartbeat_timeouts, 0u) << i;
  }
}

// The host stops (it died, or its loop stalled): no heartbeat, no SYNC, no RPDO. Every drive's consumer faults it
// (EMCY 0x8130, its fault reaction) drive_consumer_timeout_ms after the host's last heartbeat; a host that comes
// back reads the fault by name and every drive is out of Operation Enabled. With the consumer off the drives would
// stay enabled, holding their last torque.
TEST(Cia402Arm, AHostThatDiesLeavesEveryDriveInItsFaultReaction) {
  for (const double consumer_ms : {300.0, 150.0, 0.0}) {
    ArmSection s = Cia402Section();
    s.cia402.drive_consumer_timeout_ms = consumer_ms;
    Cia402ArmRig rig(s);
    for (int k = 0; k < 50; ++k) rig.Cycle(Eigen::Vector3d::Zero());
    // Stop right after a heartbeat went out, so the time to the fault is the consumer's.
    const std::uint64_t sent = rig.bus->host_heartbeat(0)->counters().sent;
    while (rig.bus->host_heartbeat(0)->counters().sent == sent) rig.Cycle(Eigen::Vector3d::Zero());
    ASSERT_EQ(rig.r.faults, kFaultNone) << rig.arm->ActuatorFaultText();
    int ms = 0;
    for (; ms < 400 && rig.plant->drive(0).drive_state() == fieldbus::cia402::DriveState::kOperationEnabled; ++ms) {
      rig.plant->timebase().wait_ns(1'000'000);
    }
    if (consumer_ms == 0.0) {
      EXPECT_EQ(ms, 400);
      for (int i = 0; i < 7; ++i) {
        EXPECT_EQ(rig.plant->drive(i).drive_state(), fieldbus::cia402::DriveState::kOperationEnabled) << i;
      }
      continue;
    }
    std::printf("consumer %g ms: drive 1 faulted %d ms after the host stopped\n", consumer_ms, ms);
    EXPECT_GE(ms, consumer_ms - 2.0);
    EXPECT_LE(ms, consumer_ms + 2.0);
    rig.plant->timebase().wait_ns(5'000'000);
    for (int i = 0; i < 7; ++i) {
      EXPECT_NE(rig.plant->drive(i).drive_state(), fieldbus::cia402::DriveState::kOperationEnabled) << i;
      EXPECT_EQ(rig.plant->drive(i).error_code(), fieldbus::canopen::emcy::kHeartbeatError) << i;
    }
    for (int k = 0; k < 3; ++k) rig.Cycle(Eigen::Vector3d::Zero());  // the host comes back
    EXPECT_EQ(rig.r.faults, kFaultCommunication);
    EXPECT_EQ(rig.arm->arm_faults(), kArmFaultActuator | kArmFaultNoReply);
    const std::string text = rig.arm->ActuatorFaultText();
    std::printf("%s\n", text.c_str());
    EXPECT_EQ(text.rfind("joint 1 'joint1': the drive lost the host's heartbeat", 0), 0u) << text;
    EXPECT_NE(text.find("(code 0x8130)"), std::string::npos) << text;
    EXPECT_TRUE(rig.NoneEnabled());
  }
}

TEST(Cia402Arm, TheCycleDoesNotAllocate) {
  Cia402ArmRig rig;
  for (int k = 0; k < 10; ++k) rig.Cycle(Eigen::Vector3d(1, 2, -3));
  test::AllocationCounter counter;
  for (int k = 0; k < 100; ++k) rig.Cycle(Eigen::Vector3d(1, 2, -3));
  rig.arm->SetSafe();
  rig.arm->Update(kPeriod_s);
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_EQ(rig.r.faults, kFaultNone);
}

// ---- the YAML section -----------------------------------------------------------------------------------------

std::any ReadSection(const std::string& yaml) {
  static const std::string file = kRobots + "/config.yaml";
  const YAML::Node node = YAML::Load(yaml);
  const config::Field field(node, "device.arm", &file);
  return FindDevice("arm")->read(&field, SectionContext{Role::kSlave, 3});
}

std::string Cia402Yaml(const std::string& head, const int (&buses)[7]) {
  std::string joints;
  for (int i = 0; i < 7; ++i) {
    joints += "    - {bus: " + std::to_string(buses[i]) + ", node_id: " + std::to_string(i + 1) +
              ", rated_torque_Nm: " + std::to_string(kEffort_Nm[i] / 2) +
              ", max_torque_Nm: " + std::to_string(kEffort_Nm[i]) + "}\n";
  }
  return "urdf: arm_7dof.urdf\nbase_link: base\ntool_link: tool\nactuators: cia402\n"
         "simulation: {initial_q_rad: [0, 0.6, 0, -1.4, 0, 0.9, 0]}\ncia402:\n" +
         head + "  joints:\n" + joints;
}

TEST(Cia402Arm, ARigThatDoesNotFitItsBusesIsRefusedSayingWhatFits) {
  constexpr int kOneBus[7] = {0, 0, 0, 0, 0, 0, 0};
  const std::string can = "  bus: can\n  buses:\n" + std::string(4, ' ') + "- {medium: socketcan, interface: can0}\n";
  try {
    (void)ReadSection(Cia402Yaml(can, kOneBus));
    ADD_FAILURE() << "7 drives at 1 kHz accepted on one classic 1 Mbit/s bus";
  } catch (const Error& e) {
    const std::string m = e.what();
    std::printf("%s\n", m.c_str());
    EXPECT_NE(m.find("bus 0 carries 7 CiA 402 drives at 1000 Hz"), std::string::npos) << m;
    EXPECT_NE(m.find("load 2.3"), std::string::npos) << m;
    EXPECT_NE(m.find("what fits: 2 drives per bus at 1000 Hz (4 buses for 7 joints), or a rate of at most 339 Hz"),
              std::string::npos)
        << m;
  }
  EXPECT_NO_THROW((void)ReadSection(Cia402Yaml(can + "  rate_hz: 330\n", kOneBus)));  // 0.78 of the bus
  std::string four = "  bus: can\n  buses:\n";
  for (int b = 0; b < 4; ++b) four += "    - {medium: socketcan, interface: can" + std::to_string(b) + "}\n";
  const auto section = std::any_cast<ArmSection>(ReadSection(Cia402Yaml(four, kBus)));
  EXPECT_TRUE(section.cia402_actuators);
  EXPECT_EQ(section.cia402.bus_count(), 4);
  EXPECT_EQ(section.cia402.buses[3].interface_name, "can3");
  EXPECT_DOUBLE_EQ(section.cia402.joints[0].rated_torque_Nm, 88.0);
}

TEST(Cia402Arm, TheSimulatedYamlRigBuildsAndRuns) {
  DeviceConfig config;
  config.backend = "arm";
  config.dof = 3;
  config.section = ReadSection(Cia402Yaml("  bus: simulated\n", kBus));
  const std::unique_ptr<Device> device = MakeDevice(config);
  BusExchange* exchange = ExchangeOf(*device);
  ASSERT_NE(exchange, nullptr);
  device->Configure();
  device->Activate();
  Reading r;
  for (int k = 0; k < 200; ++k) {
    exchange->Exchange();
    device->Read(r);
    device->Write(Command::Force(DofVector::Zero(3)));
    device->Update(kPeriod_s);
  }
  EXPECT_EQ(r.faults, kFaultNone);
  device->Deactivate();
}

}  // namespace
// The host's node-ID is a key (cia402.host_node_id, default 127): a bus whose node 127 is taken moves the host to
// another; each drive's consumer (0x1016:01) and the heartbeat producers follow it, and a drive on it is refused.
TEST(Cia402Arm, TheHostsHeartbeatNodeIdIsConfigurable) {
  constexpr int kOneBusEach[7] = {0, 0, 1, 1, 2, 2, 3};
  const auto section =
      std::any_cast<ArmSection>(ReadSection(Cia402Yaml("  bus: simulated\n  host_node_id: 100\n", kOneBusEach)));
  EXPECT_EQ(section.cia402.host_node_id, 100);
  EXPECT_EQ(std::any_cast<ArmSection>(ReadSection(Cia402Yaml("  bus: simulated\n", kOneBusEach))).cia402.host_node_id,
            127);
  EXPECT_THROW((void)ReadSection(Cia402Yaml("  bus: simulated\n  host_node_id: 128\n", kOneBusEach)), Error);
  ArmSection s = Cia402Section();
  s.cia402.host_node_id = 100;
  Cia402ArmRig rig(s);
  for (int i = 0; i < 7; ++i) EXPECT_EQ(rig.plant->drive(i).consumer_heartbeat(), (100u << 16) | 300u) << i;
  for (int k = 0; k < 200; ++k) rig.Cycle(Eigen::Vector3d::Zero());
  EXPECT_EQ(rig.r.faults, kFaultNone) << rig.arm->ActuatorFaultText();
  for (int i = 0; i < 7; ++i) EXPECT_EQ(rig.plant->drive(i).counters().host_heartbeat_timeouts, 0u) << i;
  ArmSection taken = Cia402Section();
  taken.cia402.host_node_id = 3;  // joint 3's drive
  try {
    (void)MakeCia402JointBus(taken);
    ADD_FAILURE() << "a drive on the host's heartbeat node-ID accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("node 3 is the host's heartbeat node-ID"), std::string::npos) << e.what();
  }
}

TEST(Cia402Arm, AConsumerNotAboveTheHostHeartbeatIsRefused) {
  ArmSection s = Cia402Section();
  s.cia402.drive_consumer_timeout_ms = 100.0;  // the host's period: one late heartbeat would fault every drive
  EXPECT_THROW((void)MakeCia402JointBus(s), Error);
  constexpr int kOneBusEach[7] = {0, 0, 1, 1, 2, 2, 3};
  try {
    (void)ReadSection(Cia402Yaml("  bus: simulated\n  drive_consumer_timeout_ms: 80\n", kOneBusEach));
    ADD_FAILURE() << "a consumer below the host's heartbeat period accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("must be 0 (off) or more than host_heartbeat_period_ms (100 ms)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW((void)ReadSection(Cia402Yaml("  bus: simulated\n  drive_consumer_timeout_ms: 0\n", kOneBusEach)));
}

}  // namespace teleop::device::arm
