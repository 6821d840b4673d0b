#include "device/hybrid/hybrid_backend.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"

namespace teleop::device::hybrid {
namespace {

TEST(HybridBackend, IsRegisteredWithTwoDofAndBrakes) {
  ASSERT_NE(FindDevice("hybrid"), nullptr);
  const auto dev = MakeDevice(HybridDeviceConfigOf(HybridDeviceConfig{}));
  EXPECT_EQ(dev->name(), "hybrid");
  EXPECT_EQ(dev->capabilities().dof, 2);
  EXPECT_EQ(dev->capabilities().rendering, Rendering::kActiveAndDissipative);
  EXPECT_NEAR(dev->capabilities().max_force_N(0), 80.55, 0.1);
  EXPECT_TRUE(dev->capabilities().has_brake);
  const AnalysisModel model = DeviceModel(HybridDeviceConfigOf(HybridDeviceConfig{}));
  ASSERT_TRUE(model.applicable);
  EXPECT_GT(model.mass_kg(0), 0.3);
  DeviceConfig one = HybridDeviceConfigOf(HybridDeviceConfig{});
  one.dof = 1;
  EXPECT_THROW((void)MakeDevice(one), Error);
}

// As a master: a force command pushing +y is rendered (by the motors: no motion to resist yet) and moves the handle.
// A command resisting the motion engages the brakes; the rendered force is reported; NaN is refused as a fault.
TEST(HybridBackend, RendersCommandsThroughTheAllocation) {
  HybridDevice dev{HybridDeviceConfig{}};
  Reading r;
  dev.Read(r);
  EXPECT_NEAR(r.position_m.norm(), 0.0, 1e-12);
  DofVector f = DofVector::Zero(2);
  f << 0.0, 10.0;
  for (int k = 0; k < 100; ++k) {
    dev.Write(Command::Force(f));
    dev.Update(1e-3);
  }
  dev.Read(r);
  EXPECT_GT(r.position_m(1), 0.001);
  EXPECT_GT(r.velocity_m_per_s(1), 0.0);
  EXPECT_NEAR(r.rendered_force_N(1), 10.0 - 2.5, 2.5);  // minus brake drag and friction
  f << 0.0, -30.0;                                      // now resist the +y motion: dissipative, the brakes take part
  dev.Write(Command::Force(f));
  dev.Update(1e-3);
  EXPECT_TRUE(dev.last_allocation().brake_engaged[0] || dev.last_allocation().brake_engaged[1]);
  f << std::nan(""), 0.0;
  dev.Write(Command::Force(f));
  dev.Update(1e-3);
  dev.Read(r);
  EXPECT_NE(r.faults & kFaultDriver, 0u);
}

// Safe state: motors off, brakes on: a moving handle is stopped, and the device never pushes.
TEST(HybridBackend, SafeStateBrakesTheHandleToRest) {
  HybridDevice dev{HybridDeviceConfig{}};
  DofVector f = DofVector::Zero(2);
  f << 20.0, 20.0;
  for (int k = 0; k < 50; ++k) {
    dev.Write(Command::Force(f));
    dev.Update(1e-3);
  }
  Reading r;
  dev.Read(r);
  ASSERT_GT(r.velocity_m_per_s.norm(), 0.05);
  dev.SetSafe();
  for (int k = 0; k < 300; ++k) dev.Update(1e-3);
  dev.Read(r);
  EXPECT_LT(r.velocity_m_per_s.norm(), 1e-9);
  EXPECT_EQ(r.rendered_force_N.norm(), 0.0);
  EXPECT_EQ(dev.rig().state().motor_joint_Nm.norm() < 1e-3, true);
}

// As a slave in contact with its simulated environment (read from YAML): the force sensor reads the wall's push.
TEST(HybridBackend, ReadsItsSectionAndRunsAsSlaveAgainstAWall) {
  const std::string yaml = R"(
role: slave
dof: 2
rate_hz: 1000
link: {security: {mode: insecure}, transport: udp, bind: "127.0.0.1:47112", peer: "127.0.0.1:47111", timeout_ms: 50}
law: {kp_N_per_m: 600, kd_Ns_per_m: 2, kv_Ns_per_m: 0, kf: 0, max_force_N: 60, velocity_filter_hz: 200}
device:
  backend: hybrid
  hybrid:
    initial_position_m: [0.0, 0.2]
    brake: {hysteresis_Nm: 0.1}
    effect: {type: wall, model: hybrid, point_m: [0, 0.25], normal: [0, 1]}
    environment: {point_m: [0, 0.21], normal: [0, 1], stiffness_N_per_m: 3000}
stability: {check: false}
)";
  const auto config = config::ParseProcessConfig(yaml, "test.yaml");
  ASSERT_EQ(config.device.backend, "hybrid");
  const auto dev = MakeDevice(config.device);
  DofVector f = DofVector::Zero(2);
  f << 0.0, 40.0;
  for (int k = 0; k < 500; ++k) {
    dev->Write(Command::Force(f));
    dev->Update(1e-3);
  }
  Reading r;
  dev->Read(r);
  // In contact: the sensor reads the environment's push-back. The 40 N command is larger than the environment's
  // push, the Fig. 5(b) case (Kwon & Song §3: "when the reaction force of the virtual wall is larger than the force
  // exerted by the human operator and the end-effector is released ... the brake can exert only a reaction force
  // against its outward motion"): the brakes stay released and the motors alone compress the environment until it
  // pushes back 40 N, at 10 mm + 40 N / 3000 N/m = 23.3 mm. Tolerance: what resists the last of that motion with the
  // brakes released, per joint the drag 0.08 N·m × 5, the remanence 2 % × 4 N·m × 5 and the joints' Coulomb friction
  // 0.1 N·m: 0.9 N·m, about 5.2 N at the handle (2.3 N per 0.4 N·m, docs/hybrid.md), which can stop the handle short
  // by up to 5.2 N / 3000 N/m = 1.7 mm. The old rule stalled it with the brakes between 10 and 40 N.
  EXPECT_LT(r.force_N(1), -40.0 + 5.2);
  EXPECT_GT(r.force_N(1), -40.5);
  EXPECT_NEAR(r.position_m(1), 0.0233 - 0.00085, 0.00086);
  EXPECT_EQ(r.faults, kFaultNone);
}

// Item 1 of the PO/PC fix in the device: the observer books the force the motors actually apply, so its actuator
// model is the configured motor (motor.time_constant_s), not the observer's own default of 0.5 ms.
TEST(HybridBackend, PoPcWallObservesTheConfiguredMotorLag) {
  const std::string yaml = R"(
role: master
dof: 2
rate_hz: 1000
link: {security: {mode: insecure}, transport: udp, bind: "127.0.0.1:47111", peer: "127.0.0.1:47112", timeout_ms: 50}
law: {kp_N_per_m: 600, kd_Ns_per_m: 2, kv_Ns_per_m: 0, kf: 0, max_force_N: 60, velocity_filter_hz: 200}
device:
  backend: hybrid
  hybrid:
    motor: {time_constant_s: 0.007}
    effect: {type: wall, model: popc, point_m: [0, 0.25], normal: [0, 1], max_force_N: 80}
stability: {check: false}
)";
  const auto config = config::ParseProcessConfig(yaml, "test.yaml");
  const auto dev = MakeDevice(config.device);
  const auto* hybrid = dynamic_cast<const HybridDevice*>(dev.get());
  ASSERT_NE(hybrid, nullptr);
  EXPECT_EQ(hybrid->wall().config().kind, WallKind::kSpringPoPc);
  EXPECT_EQ(hybrid->wall().config().popc.actuator_time_constant_s, 0.007);
  EXPECT_EQ(hybrid->wall().config().popc.max_force_N, 80.0);  // it saturates where the wall does, before observing
}

TEST(HybridBackend, BadSectionIsRejectedWithItsKey) {
  const std::string yaml = R"(
role: master
dof: 2
rate_hz: 1000
link: {security: {mode: insecure}, transport: udp, bind: "127.0.0.1:47111", peer: "127.0.0.1:47112", timeout_ms: 50}
law: {kp_N_per_m: 600, kd_Ns_per_m: 2, kv_Ns_per_m: 0, kf: 0, max_force_N: 60, velocity_filter_hz: 200}
device:
  backend: hybrid
  hybrid:
    effect: {type: wall, model: bouncy}
stability: {check: false}
)";
  try {
    (void)config::ParseProcessConfig(yaml, "bad.yaml");
    FAIL() << "accepted a bad wall model";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("spring, popc, hybrid or linear-damper"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace teleop::device::hybrid
