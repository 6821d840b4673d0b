#include "device/hybrid/hybrid_device.hpp"

#include <Eigen/LU>
#include <cmath>

#include "device/hybrid/force_manipulability.hpp"
#include "teleop/error.hpp"

namespace teleop::device::hybrid {

void HybridDeviceConfig::Validate() const {
  rig.Validate();
  allocation.Validate();
  effect.wall.Validate();
  effect.friction.Validate();
  if (!(std::isfinite(hand_mass_kg) && hand_mass_kg >= 0.0))
    throw Error("device.hybrid: operator.mass_kg must be >= 0");
  if (!environment.point_m.allFinite() || !environment.normal.allFinite() ||
      std::abs(environment.normal.norm() - 1.0) > 1e-6 || !(environment.stiffness_N_per_m >= 0.0) ||
      !(environment.damping_Ns_per_m >= 0.0)) {
    throw Error("device.hybrid: environment needs a finite point, a unit normal and stiffness/damping >= 0");
  }
}

namespace {

HybridRigConfig WithHand(HybridRigConfig rig, double hand_mass_kg) {
  rig.handle_mass_kg += hand_mass_kg;
  return rig;
}

AllocationConfig Synced(AllocationConfig a, const HybridRigConfig& rig) {
  a.motor = rig.motor;
  a.brake = AllocationBrakeModel(rig.brake, a.brake_model_mismatch);  // the simulated brake is not its model
  return a;
}

// The PO/PC observer books the force the motors apply (Hannaford & Ryu, docs/hybrid.md): its actuator model is the
// rig's motor (motor.time_constant_s), as in the scenarios, not the observer's default.
WallConfig ObservingTheMotor(WallConfig w, const HybridRigConfig& rig) {
  w.popc.actuator_time_constant_s = rig.motor.time_constant_s;
  return w;
}

OperatorHandConfig HandAt(OperatorHandConfig h, const Eigen::Vector2d& start) {
  h.start_m = start;
  return h;
}

}  // namespace

HybridDevice::HybridDevice(const HybridDeviceConfig& config)
    : config_(config),
      rig_(WithHand(config.rig, config.hand_mass_kg)),
      allocator_(Synced(config.allocation, config.rig)),
      wall_(ObservingTheMotor(config.effect.wall, config.rig)),
      hand_(HandAt(config.hand, config.rig.initial_position_m)),
      encoders_(config.rig.encoders),
      force_sensor_(config.rig.force_sensor_dynamics) {
  config_.Validate();
  encoders_.Reset(rig_.state().joint_rad);
  Sense();
  // Capabilities: the FME minimum over the workspace, the force available in every direction everywhere.
  const FmeMap map = MapForceManipulability(rig_.kinematics(), config_.rig.motor.MaxJointTorqueNm(),
                                            config_.rig.brake.max_torque_Nm * config_.rig.brake.pulley_ratio, 0.01);
  capabilities_.dof = 2;
  capabilities_.rendering = config_.allocation.use_brakes ? Rendering::kActiveAndDissipative : Rendering::kActiveForce;
  capabilities_.max_force_N = DofVector::Constant(2, map.min_motor_force_N);
  capabilities_.has_brake = config_.allocation.use_brakes;
  capabilities_.max_brake_force_N = DofVector::Constant(2, config_.allocation.use_brakes ? map.min_brake_force_N : 0.0);
  capabilities_.measures_velocity = true;
  capabilities_.measures_force = true;
}

void HybridDevice::Sense() noexcept {
  const RigState& s = rig_.state();
  Eigen::Vector2d p;
  Eigen::Matrix2d jac;
  if (rig_.kinematics().Forward(encoders_.joint_rad(), p) && rig_.kinematics().Jacobian(encoders_.joint_rad(), jac)) {
    sensed_position_m_ = p;
    sensed_velocity_m_per_s_ = jac * encoders_.joint_velocity_rad_per_s();
  } else {
    sensed_position_m_ = s.position_m;
    sensed_velocity_m_per_s_ = s.velocity_m_per_s;
  }
}

void HybridDevice::Read(Reading& out) noexcept {
  const RigState& s = rig_.state();
  out.position_m = DofVector::Zero(2);
  out.velocity_m_per_s = DofVector::Zero(2);
  out.force_N = DofVector::Zero(2);
  out.rendered_force_N = DofVector::Zero(2);
  out.faults = kFaultNone;
  const Eigen::Vector2d rel = sensed_position_m_ - config_.rig.initial_position_m;
  out.position_m << rel.x(), rel.y();
  out.velocity_m_per_s << sensed_velocity_m_per_s_.x(), sensed_velocity_m_per_s_.y();
  out.force_N << sensed_force_N_.x(), sensed_force_N_.y();
  if (!safe_) out.rendered_force_N << s.rendered_force_N.x(), s.rendered_force_N.y();
  if (!out.position_m.allFinite() || !out.velocity_m_per_s.allFinite() || !out.force_N.allFinite()) {
    out.faults |= kFaultNonFiniteSensor;
  }
  if (s.singular || !rig_.kinematics().InWorkspace(s.position_m)) out.faults |= kFaultOutOfRange;
  if (bad_command_) out.faults |= kFaultDriver;
}

void HybridDevice::Write(const Command& command) noexcept {
  safe_ = false;
  bad_command_ = command.force_N.size() != 2 || !command.force_N.allFinite();
  desired_N_ = bad_command_ ? Eigen::Vector2d::Zero() : Eigen::Vector2d(command.force_N(0), command.force_N(1));
}

void HybridDevice::SetSafe() noexcept {
  safe_ = true;
  desired_N_.setZero();
}

void HybridDevice::Update(double period_s) noexcept {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) return;
  last_period_s_ = period_s;
  const RigState& s = rig_.state();
  // Forces on the handle from outside: the simulated operator and the simulated environment.
  Eigen::Vector2d external = Eigen::Vector2d::Zero();
  if (config_.simulated_operator) external += hand_.Force(time_s_, s.position_m, s.velocity_m_per_s);
  if (config_.environment.wall) {
    const Eigen::Vector2d& n = config_.environment.normal;
    const double depth = (s.position_m - config_.environment.point_m).dot(n);
    if (depth > 0.0) {
      const double f = config_.environment.stiffness_N_per_m * depth +
                       config_.environment.damping_Ns_per_m * s.velocity_m_per_s.dot(n);
      if (f > 0.0) external -= f * n;
    }
  }
  // The handle sensor's reading of this cycle's external force (noise, bandwidth), which Read then reports.
  sensed_force_N_ = force_sensor_.Filter(MeasureHandleForce(config_.rig.force_sensor, external), period_s);
  const Eigen::Vector2d& measured = sensed_force_N_;
  Eigen::Vector2d motor = Eigen::Vector2d::Zero();
  Eigen::Vector2d brake = Eigen::Vector2d::Zero();
  Eigen::Matrix2d jac;
  if (safe_ || !rig_.kinematics().Jacobian(encoders_.joint_rad(), jac)) {
    brake.setConstant(config_.rig.brake.max_torque_Nm);  // safe state: motors off, brakes engaged
    allocator_.Reset();
  } else {
    AllocationInput in;
    in.jacobian_m_per_rad = jac;
    in.joint_velocity_rad_per_s = encoders_.joint_velocity_rad_per_s();
    in.hand_force_N = measured.allFinite() ? measured : Eigen::Vector2d::Zero();
    in.desired_force_N = desired_N_;
    switch (config_.effect.kind) {
      case HybridEffectConfig::Kind::kNone:
        break;
      case HybridEffectConfig::Kind::kWall: {
        const WallOutput w = wall_.Step(sensed_position_m_, sensed_velocity_m_per_s_, period_s);
        in.motor_force_N = w.motor_force_N;
        in.desired_force_N += w.desired_force_N;
        in.dissipative_force_N = w.dissipative_force_N;
        break;
      }
      case HybridEffectConfig::Kind::kFriction: {
        const FrictionOutput f =
            FrictionStep(config_.effect.friction, sensed_position_m_, sensed_velocity_m_per_s_, in.hand_force_N);
        in.desired_force_N += f.desired_force_N;
        in.dissipative_force_N = f.dissipative_force_N;
        break;
      }
    }
    allocation_out_ = allocator_.Step(in, period_s);
    motor = allocation_out_.motor_joint_Nm;
    brake = allocation_out_.brake_shaft_Nm;
  }
  rig_.Step(motor, brake, external, period_s);
  encoders_.Sample(rig_.state().joint_rad, rig_.state().joint_velocity_rad_per_s, period_s);
  Sense();
  time_s_ += period_s;
}

}  // namespace teleop::device::hybrid
