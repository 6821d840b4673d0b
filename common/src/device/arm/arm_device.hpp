#pragma once

// The arm backend's device (docs/arms.md): a chain plus one joint actuator per joint (joint_actuator.hpp), presented
// to the node as the task-space device it knows (dof 3: the tool point's x, y, z in the base frame).
//   Read:  q, q̇ from the actuators; p_BT by forward kinematics, v_BT = J_v·q̇; no force sensor (measures_force
//          false); faults: a non-finite joint reading, a joint beyond its limit, a singular configuration
//          (translational manipulability below the bound), an actuator fault.
//   Write: τ from the torque law (arm_torque.hpp), clamped to each joint's effort limit (kWarningSaturated when a
//          joint was clamped; the rendered force says by how much).
//   Safe:  the arm holds its own weight: τ = G(q), the coupling force zero.

#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "arm_model.hpp"
#include "arm_torque.hpp"
#include "joint_actuator.hpp"
#include "teleop/device/bus_exchange.hpp"
#include "teleop/device/device.hpp"

namespace teleop::device::arm {

/// The arm's own fault detail (which check tripped), beside the node's FaultBits.
enum ArmFaultBits : std::uint32_t {
  kArmFaultNone = 0,
  kArmFaultNonFinite = 1u << 0,
  kArmFaultJointLimit = 1u << 1,
  kArmFaultSingular = 1u << 2,
  kArmFaultActuator = 1u << 3,
  kArmFaultModel = 1u << 4,            ///< KDL could not evaluate the model at q.
  kArmFaultCommand = 1u << 5,          ///< A command of the wrong size or non-finite (replaced by zero force).
  kArmFaultNoReply = 1u << 6,          ///< An actuator stopped answering on its bus (with kArmFaultActuator).
  kArmFaultOverTemperature = 1u << 7,  ///< An actuator reports over-temperature (with kArmFaultActuator).
};

/// The arm's own warnings (the node's WarningBits have no temperature bit): arm_warnings().
enum ArmWarningBits : std::uint32_t {
  kArmWarningNone = 0,
  kArmWarningTemperature = 1u << 0,  ///< An actuator reports a temperature at or above its warning threshold.
};

struct ArmDeviceConfig {
  ArmTorqueConfig torque;
  double min_manipulability = 1e-4;  ///< Below this √det(J_v J_vᵀ) the configuration is singular (a fault).
  /// The reported position is p_BT − workspace_origin_m (m, base frame): the working point the pair couples around.
  Eigen::Vector3d workspace_origin_m = Eigen::Vector3d::Zero();
};

class ArmDevice final : public Device, public BusExchange {
 public:
  /// Takes the model and the bus (their joint counts must agree). Throws teleop::Error.
  ArmDevice(std::unique_ptr<ArmModel> model, std::unique_ptr<JointBus> bus, ArmDeviceConfig config);

  const Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override { return name_; }
  void Configure() override { bus_->Configure(); }
  void Activate() override;
  void Deactivate() noexcept override;
  /// The bus's StartCycle (JointBus): a CiA 402 bus's TPDOs in and its SYNC out; nothing for the others.
  void Exchange() noexcept override { bus_->StartCycle(); }

  void Read(Reading& out) noexcept override;
  void Write(const Command& command) noexcept override;
  void Update(double period_s) noexcept override;
  void SetSafe() noexcept override;
  /// Read() publishes q there each cycle (when every joint reading is finite).
  ConfigurationMailbox* configuration_mailbox() noexcept override { return &configuration_; }

  // Inspection (tests, telemetry).
  std::uint32_t arm_faults() const noexcept { return arm_faults_; }
  /// ArmWarningBits of the last Read.
  std::uint32_t arm_warnings() const noexcept { return arm_warnings_; }
  /// The first actuator fault since Activate (or construction), by name: "joint 4 'joint4': coil over-temperature
  /// (code 0xC)"; empty when none. Not for the cycle (it allocates).
  std::string ActuatorFaultText() const;
  /// Every fault of the first faulted reading since Activate, by name: the actuator's (ActuatorFaultText), the
  /// joint beyond its limits, a singular configuration, a non-finite reading. Any thread.
  std::string FaultText() const override;
  const JointVector& q() const noexcept { return q_; }
  const ArmModel& model() const noexcept { return *model_; }
  const ArmTorque& torque() const noexcept { return torque_; }

 private:
  /// Reads every joint into q_, v_ and `out`'s joint vectors: the ArmFaultBits they show (latching the first
  /// actuator fault and the first joint beyond its limits), their warnings into `arm_warnings`.
  std::uint32_t ReadJoints(Reading& out, std::uint32_t& arm_warnings) noexcept;
  void Apply(const Eigen::Vector3d& force_N, bool coupling) noexcept;

  std::string name_ = "arm";
  Capabilities capabilities_;
  std::unique_ptr<ArmModel> model_;
  std::unique_ptr<JointBus> bus_;
  ArmDeviceConfig config_;
  ArmTorque torque_;
  int n_ = 0;
  JointVector q_, v_;
  JointSample sample_;
  bool model_valid_ = false;
  bool hold_captured_ = false;
  std::uint32_t arm_faults_ = kArmFaultNone;
  // Latched by Read() at the first faulted reading since Activate, for FaultText on another thread: the joint
  // and code first, then the fault word (release), which FaultText reads first (acquire).
  std::atomic<int> first_fault_joint_{-1};  ///< The first actuator fault's joint (ActuatorFaultText).
  std::atomic<std::uint32_t> first_fault_code_{0};
  std::atomic<int> first_limit_joint_{-1};  ///< The first joint found beyond its limits.
  std::atomic<std::uint32_t> first_arm_faults_{kArmFaultNone};
  static_assert(std::atomic<int>::is_always_lock_free && std::atomic<std::uint32_t>::is_always_lock_free,
                "written by the cycle, read by the event log's thread, wait-free");
  std::uint32_t faults_ = kFaultNone;
  std::uint32_t command_faults_ = kFaultNone;
  std::uint32_t warnings_ = kWarningNone;
  std::uint32_t arm_warnings_ = kArmWarningNone;
  Eigen::Vector3d rendered_N_ = Eigen::Vector3d::Zero();
  DeviceConfiguration published_;  ///< Filled in Read(), copied into configuration_.
  ConfigurationMailbox configuration_;
};

}  // namespace teleop::device::arm
