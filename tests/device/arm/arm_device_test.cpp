// The arm backend (common/src/device/arm): the torque law's null-space term leaves the tool force unchanged, the
// commanded gravity torque holds the simulated arm still, the cycle does not allocate, each fault is its bit and the
// safe state holds the arm's weight, a clamp is reported, and the YAML section builds the device through the registry.

#include "arm_device.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <random>
#include <string>

#include "arm_section.hpp"
#include "arm_torque.hpp"
#include "simulated_arm.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::device::arm {
namespace {

const std::string kRobots = TELEOP_ROBOTS_DIR;
constexpr double kPeriod_s = 0.001;

ArmSection SevenJoint() {
  ArmSection s;
  s.chain.urdf_file = kRobots + "/arm_7dof.urdf";
  s.chain.base_link = "base";
  s.chain.tool_link = "tool";
  s.device.min_manipulability = 1e-4;
  return s;
}

JointVector RandomQ(const ArmChain& arm, std::mt19937& rng, double margin) {
  JointVector q(arm.joint_count());
  for (int i = 0; i < arm.joint_count(); ++i) {
    const JointSpec& j = arm.joints[static_cast<std::size_t>(i)];
    q[i] = std::uniform_real_distribution<double>(j.lower + margin, j.upper - margin)(rng);
  }
  return q;
}

std::vector<double> ToList(const JointVector& q) { return {q.data(), q.data() + q.size()}; }

// The task-space force a joint torque τ renders, Λ·J_t·M⁻¹·τ with Λ = (J_t·M⁻¹·J_tᵀ)⁻¹, computed here in long
// double (independent of the law's own double-precision arithmetic).
Eigen::Matrix<long double, Eigen::Dynamic, 1> TaskForceOf(const ArmModel& model, int rows, const JointVector& tau) {
  using MatrixL = Eigen::Matrix<long double, Eigen::Dynamic, Eigen::Dynamic>;
  const MatrixL M = model.M_q().cast<long double>();
  const MatrixL J = model.J_BT().topRows(rows).cast<long double>();
  const MatrixL Minv_Jt = M.llt().solve(J.transpose());
  const MatrixL Lambda_inv = J * Minv_Jt;
  const Eigen::Matrix<long double, Eigen::Dynamic, 1> a = J * M.llt().solve(tau.cast<long double>());
  return Lambda_inv.fullPivLu().solve(a);
}

// The posture term must not change the tool force: the task-space force a torque τ renders is J̄ᵀτ (the
// dynamically consistent inverse), so J̄ᵀ·τ_posture = 0, for translation and, with orientation hold, the moment.
TEST(ArmTorque, NullSpacePostureLeavesTheToolForceUnchanged) {
  for (const bool hold : {false, true}) {
    ArmModel model(BuildArmChain(SevenJoint().chain), Eigen::Vector3d(0, 0, -9.81));
    ArmTorqueConfig config;
    config.hold_orientation = hold;
    config.orientation_stiffness_Nm_per_rad = 30.0;
    config.posture_stiffness_Nm_per_rad = 50.0;
    config.posture_damping_Nms_per_rad = 2.0;
    ArmTorque law(model, config);
    std::mt19937 rng(1);
    int checked = 0;
    double largest_posture_Nm = 0.0;
    for (int trial = 0; trial < 200; ++trial) {
      const JointVector q = RandomQ(model.arm(), rng, 0.05);
      const JointVector v(JointVector::Random(7));
      ASSERT_TRUE(model.Update(q, v));
      if (model.TranslationalManipulability() < 1e-3) continue;  // near-singular: the arm faults there anyway
      const Eigen::Vector3d f(3.0, -2.0, 5.0);
      const ArmTorqueTerms& t = law.Step(model, q, v, f, true);
      ASSERT_TRUE(t.null_space_valid);
      const Eigen::Matrix<long double, Eigen::Dynamic, 1> wrench = TaskForceOf(model, hold ? 6 : 3, t.posture_Nm);
      EXPECT_LT(wrench.head<3>().norm(), 1e-9) << "hold " << hold << " trial " << trial;
      if (hold) {
        EXPECT_LT(wrench.tail<3>().norm(), 1e-9);
      }
      // And the force term alone renders exactly F.
      const TaskVector rendered(law.J_bar().transpose() * t.task_Nm);
      EXPECT_LT((rendered.head<3>() - f).norm(), 1e-9);
      largest_posture_Nm = std::max(largest_posture_Nm, t.posture_Nm.norm());
      ++checked;
    }
    EXPECT_GT(checked, 150);
    EXPECT_GT(largest_posture_Nm, 1.0);  // the term is there: the check is not of zero
  }
}

// The static check: with zero force and gravity compensation only, the simulated arm stays where it is; without
// the compensation it falls (so the check can fail).
TEST(ArmDevice, CommandedGravityTorqueHoldsTheSimulatedArmStill) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 5; ++trial) {
    ArmSection s = SevenJoint();
    s.simulation.encoder_resolution_rad = 2.0 * M_PI / 524288.0;  // 19-bit encoder
    const JointVector q0 = RandomQ(BuildArmChain(s.chain), rng, 0.3);
    s.initial_q_rad = ToList(q0);
    s.device.min_manipulability = 0.0;
    auto sim = MakeSimulatedArm(s);
    SimulatedArm& plant = *sim;
    ArmDevice arm(std::make_unique<ArmModel>(BuildArmChain(s.chain), s.gravity_B()), std::move(sim), s.device);
    Reading r;
    for (int k = 0; k < 1000; ++k) {
      arm.Read(r);
      ASSERT_EQ(r.faults, kFaultNone);
      arm.Write(Command::Force(DofVector::Zero(3)));
      arm.Update(kPeriod_s);
    }
    EXPECT_LT((plant.q() - q0).cwiseAbs().maxCoeff(), 1e-3) << "trial " << trial;

    // Falling without compensation: zero torque for 0.2 s.
    ArmSection free_fall = s;
    auto falling = MakeSimulatedArm(free_fall);
    for (int k = 0; k < 200; ++k) falling->Exchange(kPeriod_s);
    EXPECT_GT((falling->q() - q0).cwiseAbs().maxCoeff(), 0.01) << "trial " << trial;
  }
}

TEST(ArmDevice, ReadWriteUpdateDoNotAllocate) {
  ArmSection s = SevenJoint();
  std::mt19937 rng(9);
  s.initial_q_rad = ToList(RandomQ(BuildArmChain(s.chain), rng, 0.3));
  s.device.torque.hold_orientation = true;
  s.device.torque.orientation_stiffness_Nm_per_rad = 20.0;
  s.device.torque.posture_stiffness_Nm_per_rad = 10.0;
  s.device.torque.limit_stiffness_Nm_per_rad = 50.0;
  s.device.torque.coriolis_compensation = true;
  s.device.min_manipulability = 0.0;
  auto arm = MakeArmDevice(s);
  Reading r;
  DofVector f(3);
  f << 1.0, 2.0, -3.0;
  const Command command = Command::Force(f);
  arm->Read(r);
  arm->Write(command);
  arm->Update(kPeriod_s);
  test::AllocationCounter counter;
  for (int k = 0; k < 100; ++k) {
    arm->Read(r);
    arm->Write(command);
    arm->Update(kPeriod_s);
  }
  arm->SetSafe();
  EXPECT_EQ(counter.count(), 0u);
}

struct FaultRig {
  explicit FaultRig(const JointVector& q0, double min_manipulability = 1e-4) {
    ArmSection s = SevenJoint();
    s.initial_q_rad = ToList(q0);
    s.device.min_manipulability = min_manipulability;
    auto bus = MakeSimulatedArm(s);
    sim = bus.get();
    arm = std::make_unique<ArmDevice>(std::make_unique<ArmModel>(BuildArmChain(s.chain), s.gravity_B()), std::move(bus),
                                      s.device);
  }
  SimulatedArm* sim = nullptr;
  std::unique_ptr<ArmDevice> arm;
};

JointVector Bent() {
  JointVector q(7);
  q << 0.2, 0.6, -0.3, -1.4, 0.2, 0.9, 0.1;
  return q;
}

TEST(ArmDevice, EachFaultIsItsBitAndTheSafeStateHoldsTheArmsWeight) {
  Reading r;
  {  // fine
    FaultRig rig(Bent());
    rig.arm->Read(r);
    EXPECT_EQ(r.faults, kFaultNone);
    EXPECT_EQ(rig.arm->FaultText(), "");
  }
  {  // singular: the arm stretched straight up
    FaultRig rig(JointVector(7));
    rig.arm->Read(r);
    EXPECT_EQ(r.faults, kFaultSingular);
    EXPECT_EQ(rig.arm->arm_faults(), kArmFaultSingular);
    EXPECT_EQ(rig.arm->FaultText(), "a singular configuration (manipulability below device.arm.min_manipulability)");
  }
  {  // beyond a joint limit
    JointVector q = Bent();
    q[3] = -2.2;  // joint4's limit is -2.09
    FaultRig rig(q);
    rig.arm->Read(r);
    EXPECT_EQ(r.faults, kFaultOutOfRange);
    EXPECT_EQ(rig.arm->FaultText().rfind("joint 4 'joint4' beyond its limits [-2.09", 0), 0u) << rig.arm->FaultText();
  }
  {  // an actuator fault, then a non-finite reading
    FaultRig rig(Bent());
    rig.sim->InjectFault(4, 9);
    rig.arm->Read(r);
    EXPECT_EQ(r.faults, kFaultDriver);
    EXPECT_EQ(rig.arm->arm_faults(), kArmFaultActuator);
    EXPECT_EQ(rig.arm->FaultText(), rig.arm->ActuatorFaultText());
    EXPECT_EQ(rig.arm->FaultText().rfind("joint 5 'joint5': ", 0), 0u) << rig.arm->FaultText();
    FaultRig nan_rig(Bent());
    nan_rig.sim->InjectNonFinite(2);
    nan_rig.arm->Read(r);
    EXPECT_EQ(r.faults, kFaultNonFiniteSensor);
    EXPECT_FALSE(r.position_m.allFinite());
    EXPECT_EQ(nan_rig.arm->FaultText(), "a non-finite joint reading");
  }
  {  // the safe state: a force command after a fault renders nothing; gravity compensation keeps the arm still
    FaultRig rig(Bent());
    rig.arm->Read(r);
    rig.arm->SetSafe();
    DofVector push(3);
    push << 0.0, 0.0, -40.0;
    for (int k = 0; k < 500; ++k) {
      rig.arm->Read(r);
      rig.arm->SetSafe();  // what the node does in its safe state
      rig.arm->Update(kPeriod_s);
    }
    EXPECT_LT((rig.sim->q() - Bent()).cwiseAbs().maxCoeff(), 1e-3);
    EXPECT_EQ(rig.arm->torque().terms().task_Nm.norm(), 0.0);
    EXPECT_GT(rig.arm->torque().terms().applied_Nm.norm(), 10.0);  // it holds ~kg of arm against gravity
    EXPECT_EQ(r.rendered_force_N.norm(), 0.0);
  }
}

TEST(ArmDevice, ATorqueClampIsReportedAndTheRenderedForceSaysHowMuch) {
  FaultRig rig(Bent());
  Reading r;
  rig.arm->Read(r);
  DofVector big(3);
  big << 0.0, 0.0, -2000.0;  // far beyond the wrist's 40 N·m
  rig.arm->Write(Command::Force(big));
  rig.arm->Update(kPeriod_s);
  rig.arm->Read(r);
  EXPECT_NE(r.warnings & kWarningSaturated, 0u);
  EXPECT_GT(rig.arm->torque().terms().clamped_joints, 0);
  EXPECT_LT(std::abs(r.rendered_force_N[2]), 2000.0);
  DofVector small(3);
  small << 0.0, 0.0, -5.0;
  rig.arm->Write(Command::Force(small));
  rig.arm->Update(kPeriod_s);
  rig.arm->Read(r);
  EXPECT_EQ(r.warnings & kWarningSaturated, 0u);
  EXPECT_NEAR(r.rendered_force_N[2], -5.0, 1e-12);
}

// ---- the YAML section through the registry -----------------------------------------------------------------------

std::any ReadSection(const std::string& yaml, int dof = 3) {
  static const std::string file = kRobots + "/config.yaml";  // relative urdf paths resolve beside it
  const YAML::Node node = YAML::Load(yaml);
  const config::Field field(node, "device.arm", &file);
  const DeviceBackend* backend = FindDevice("arm");
  EXPECT_NE(backend, nullptr);
  return backend->read(&field, SectionContext{Role::kSlave, dof});
}

TEST(ArmBackend, TheYamlSectionBuildsTheDevice) {
  const std::string yaml = R"(
urdf: arm_7dof.urdf
base_link: base
tool_link: tool
orientation: hold
orientation_stiffness_Nm_per_rad: 20
posture_stiffness_Nm_per_rad: 5
joint_limits: [{joint: joint4, lower_rad: -1.9, max_effort_Nm: 90}]
actuators: simulated
simulation: {initial_q_rad: [0.2, 0.6, -0.3, -1.4, 0.2, 0.9, 0.1], viscous_Nms_per_rad: 0.5}
)";
  DeviceConfig config;
  config.backend = "arm";
  config.dof = 3;
  config.section = ReadSection(yaml);
  const std::unique_ptr<Device> device = MakeDevice(config);
  EXPECT_EQ(device->capabilities().dof, 3);
  EXPECT_FALSE(device->capabilities().measures_force);
  auto& arm = dynamic_cast<ArmDevice&>(*device);
  EXPECT_DOUBLE_EQ(arm.model().arm().joints[3].lower, -1.9);
  EXPECT_DOUBLE_EQ(arm.model().arm().joints[3].max_effort, 90.0);
  Reading r;
  device->Read(r);
  EXPECT_EQ(r.faults, kFaultNone);
  const AnalysisModel model = DeviceModel(config);
  ASSERT_TRUE(model.applicable) << model.reason;
  EXPECT_GT(model.mass_kg.minCoeff(), 0.1);
  EXPECT_GT(model.damping_Ns_per_m.minCoeff(), 0.0);
}

TEST(ArmBackend, BadSectionsAreClearErrors) {
  const std::string base = "urdf: arm_7dof.urdf\nbase_link: base\ntool_link: tool\nactuators: simulated\n";
  EXPECT_THROW(
      {
        try {
          ReadSection(base, 1);
        } catch (const Error& e) {
          EXPECT_NE(std::string(e.what()).find("task-space device of dof 3"), std::string::npos) << e.what();
          throw;
        }
      },
      Error);
  DeviceConfig config;
  config.backend = "arm";
  config.dof = 3;
  config.section = ReadSection(base + "posture_q_rad: [0, 0, 0]\n");
  try {
    (void)MakeDevice(config);
    ADD_FAILURE() << "no error for a posture of 3 joints on a 7-joint arm";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("device.arm.posture_q_rad has 3 values"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("has 7 joints"), std::string::npos) << e.what();
  }
  config.section = ReadSection("urdf: arm_7dof.urdf\nbase_link: base\ntool_link: hand\nactuators: simulated\n");
  try {
    (void)MakeDevice(config);
    ADD_FAILURE() << "no error for a missing tool link";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no link named 'hand'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace teleop::device::arm
