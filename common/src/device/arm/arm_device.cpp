// The arm backend's device (arm_device.hpp).

#include "arm_device.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::device::arm {

static_assert(kMaxJoints <= kMaxConfigurationValues, "q must fit the published configuration");

ArmDevice::ArmDevice(std::unique_ptr<ArmModel> model, std::unique_ptr<JointBus> bus, ArmDeviceConfig config)
    : model_(std::move(model)),
      bus_(std::move(bus)),
      config_(std::move(config)),
      torque_(*model_, config_.torque),
      n_(model_->joint_count()),
      q_(n_),
      v_(n_) {
  if (bus_->joint_count() != n_) {
    throw Error("arm: the actuators have " + std::to_string(bus_->joint_count()) + " joints, the chain in '" +
                model_->arm().spec.urdf_file + "' has " + std::to_string(n_));
  }
  capabilities_.dof = 3;
  capabilities_.rendering = Rendering::kActiveForce;
  capabilities_.max_force_N = DofVector::Constant(3, std::numeric_limits<double>::infinity());
  capabilities_.measures_velocity = true;
  capabilities_.measures_force = false;
  static_assert(kMaxJoints <= kMaxDof, "Reading's joint vectors hold kMaxDof entries");
  capabilities_.joints = n_;
}

void ArmDevice::Activate() {
  first_arm_faults_.store(kArmFaultNone, std::memory_order_relaxed);
  first_fault_joint_.store(-1, std::memory_order_relaxed);
  first_limit_joint_.store(-1, std::memory_order_relaxed);
  bus_->Activate();
  hold_captured_ = false;  // the orientation to hold is the one at the first Read after activation
}

void ArmDevice::Deactivate() noexcept {
  SetSafe();
  bus_->Deactivate();
}

std::uint32_t ArmDevice::ReadJoints(Reading& out, std::uint32_t& arm_warnings) noexcept {
  std::uint32_t arm = kArmFaultNone;
  out.joint_position_rad.resize(n_);  // fixed storage: no allocation
  out.joint_torque_Nm.resize(n_);
  for (int i = 0; i < n_; ++i) {
    bus_->joint(i).Read(sample_);
    q_[i] = sample_.position;
    v_[i] = sample_.velocity;
    out.joint_position_rad[i] = sample_.position;
    out.joint_torque_Nm[i] = sample_.torque_Nm;
    if (!std::isfinite(sample_.position) || !std::isfinite(sample_.velocity)) arm |= kArmFaultNonFinite;
    if (sample_.temperature_warning) arm_warnings |= kArmWarningTemperature;
    if (sample_.fault) {
      arm |= kArmFaultActuator;
      if (sample_.fault_kind == JointFaultKind::kNoReply) arm |= kArmFaultNoReply;
      if (sample_.fault_kind == JointFaultKind::kOverTemperature) arm |= kArmFaultOverTemperature;
      if (first_fault_joint_.load(std::memory_order_relaxed) < 0) {
        first_fault_code_.store(sample_.fault_code, std::memory_order_relaxed);
        first_fault_joint_.store(i, std::memory_order_relaxed);
      }
    }
    const JointSpec& j = model_->arm().joints[static_cast<std::size_t>(i)];
    if (j.bounded && (sample_.position < j.lower || sample_.position > j.upper)) {
      arm |= kArmFaultJointLimit;
      if (first_limit_joint_.load(std::memory_order_relaxed) < 0) {
        first_limit_joint_.store(i, std::memory_order_relaxed);
      }
    }
  }
  return arm;
}

void ArmDevice::Read(Reading& out) noexcept {
  std::uint32_t arm_warnings = kArmWarningNone;
  std::uint32_t arm = ReadJoints(out, arm_warnings);
  model_valid_ = false;
  if ((arm & kArmFaultNonFinite) == 0) {
    model_valid_ = model_->Update(q_, v_);
    if (!model_valid_) arm |= kArmFaultModel;
    published_.count = n_;
    for (int i = 0; i < n_; ++i) published_.values[static_cast<std::size_t>(i)] = q_[i];
    configuration_.Write(published_);
  }
  if (model_valid_ && model_->TranslationalManipulability() < config_.min_manipulability) arm |= kArmFaultSingular;
  if (model_valid_ && !hold_captured_) {
    torque_.HoldOrientation(model_->R_BT());
    hold_captured_ = true;
  }
  arm_faults_ = arm;
  if (arm != kArmFaultNone && first_arm_faults_.load(std::memory_order_relaxed) == kArmFaultNone) {
    first_arm_faults_.store(arm, std::memory_order_release);
  }
  std::uint32_t faults = command_faults_;
  if (arm & (kArmFaultNonFinite | kArmFaultModel)) faults |= kFaultNonFiniteSensor;
  if (arm & kArmFaultJointLimit) faults |= kFaultOutOfRange;
  if (arm & kArmFaultSingular) faults |= kFaultSingular;
  if (arm & kArmFaultNoReply) faults |= kFaultCommunication;
  if (arm & kArmFaultOverTemperature) faults |= kFaultOvertemperature;
  if ((arm & kArmFaultActuator) && !(arm & (kArmFaultNoReply | kArmFaultOverTemperature))) faults |= kFaultDriver;
  faults_ = faults;
  arm_warnings_ = arm_warnings;
  command_faults_ = kFaultNone;

  out.position_m.resize(3);
  out.velocity_m_per_s.resize(3);
  out.force_N = DofVector::Zero(3);
  out.rendered_force_N = DofVector(rendered_N_);
  if (model_valid_) {
    out.position_m = model_->p_BT() - config_.workspace_origin_m;
    out.velocity_m_per_s = model_->v_BT();
  } else {
    out.position_m.setConstant(std::numeric_limits<double>::quiet_NaN());
    out.velocity_m_per_s.setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  out.faults = faults_;
  out.warnings = warnings_;
}

void ArmDevice::Apply(const Eigen::Vector3d& force_N, bool coupling) noexcept {
  if (!model_valid_) {  // no model at q: nothing sensible to hold with; zero torque
    for (int i = 0; i < n_; ++i) bus_->joint(i).WriteTorque(0.0);
    rendered_N_.setZero();
    return;
  }
  const ArmTorqueTerms& t = torque_.Step(*model_, q_, v_, force_N, coupling);
  for (int i = 0; i < n_; ++i) bus_->joint(i).WriteTorque(t.applied_Nm[i]);
  warnings_ = t.clamped_joints > 0 ? kWarningSaturated : kWarningNone;
  rendered_N_ = coupling ? t.rendered_force_N : Eigen::Vector3d::Zero();
}

void ArmDevice::Write(const Command& command) noexcept {
  if (command.force_N.size() != 3 || !command.force_N.allFinite()) {
    command_faults_ |= kFaultDriver;
    arm_faults_ |= kArmFaultCommand;
    Apply(Eigen::Vector3d::Zero(), false);
    return;
  }
  if (faults_ != kFaultNone) {  // the node puts us in the safe state; never couple on a faulted reading
    Apply(Eigen::Vector3d::Zero(), false);
    return;
  }
  Apply(Eigen::Vector3d(command.force_N[0], command.force_N[1], command.force_N[2]), true);
}

std::string ArmDevice::ActuatorFaultText() const {
  const int joint = first_fault_joint_.load(std::memory_order_relaxed);
  if (joint < 0) return {};
  const std::uint32_t fault_code = first_fault_code_.load(std::memory_order_relaxed);
  char code[16];
  std::snprintf(code, sizeof code, "0x%X", fault_code);
  return "joint " + std::to_string(joint + 1) + " '" + model_->arm().joints[static_cast<std::size_t>(joint)].name +
         "': " + std::string(bus_->FaultName(fault_code)) + " (code " + code + ")";
}

std::string ArmDevice::FaultText() const {
  const std::uint32_t arm = first_arm_faults_.load(std::memory_order_acquire);
  std::string text;
  const auto add = [&text](const std::string& part) {
    if (part.empty()) return;
    if (!text.empty()) text += "; ";
    text += part;
  };
  if (arm & kArmFaultActuator) add(ActuatorFaultText());
  if (const int joint = first_limit_joint_.load(std::memory_order_relaxed); (arm & kArmFaultJointLimit) && joint >= 0) {
    const JointSpec& j = model_->arm().joints[static_cast<std::size_t>(joint)];
    char range[64];
    std::snprintf(range, sizeof range, "[%.4g, %.4g]", j.lower, j.upper);
    add("joint " + std::to_string(joint + 1) + " '" + j.name + "' beyond its limits " + range);
  }
  if (arm & kArmFaultSingular) add("a singular configuration (manipulability below device.arm.min_manipulability)");
  if (arm & kArmFaultNonFinite) add("a non-finite joint reading");
  if (arm & kArmFaultModel) add("the kinematic model could not be evaluated at this configuration");
  return text;
}

void ArmDevice::Update(double period_s) noexcept { bus_->Exchange(period_s); }

void ArmDevice::SetSafe() noexcept { Apply(Eigen::Vector3d::Zero(), false); }

}  // namespace teleop::device::arm
