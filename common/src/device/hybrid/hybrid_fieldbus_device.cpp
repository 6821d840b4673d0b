#include "teleop/device/hybrid/hybrid_fieldbus_device.hpp"

#include <Eigen/LU>
#include <cmath>

#include "teleop/device/hybrid/force_manipulability.hpp"
#include "teleop/error.hpp"

namespace teleop::device::hybrid {

using fieldbus::Cia402Status;

void HybridFieldbusConfig::Validate() const {
  geometry.Validate();
  allocation.Validate();
  fieldbus::Validate(amplifier);
  if (amplifier.outputs.size() < 2 || amplifier.inputs.size() < 2) {
    throw Error(
        "device.hybrid fieldbus: the amplifier's register map needs outputs 0, 1 (brake 1, 2 shaft torque, N·m) and "
        "inputs 0, 1 (handle force x, y, N)");
  }
  if (drives[0].node_id == drives[1].node_id)
    throw Error("device.hybrid fieldbus: the two drives need different node ids");
  if (!std::isfinite(joint_offset_rad[0]) || !std::isfinite(joint_offset_rad[1]) || !origin_m.allFinite()) {
    throw Error("device.hybrid fieldbus: joint offsets and origin must be finite");
  }
}

const char* ToString(RigFaultSource source) noexcept {
  switch (source) {
    case RigFaultSource::kNone:
      return "none";
    case RigFaultSource::kDrive1:
      return "drive 1";
    case RigFaultSource::kDrive2:
      return "drive 2";
    case RigFaultSource::kAmplifier:
      return "brake amplifier";
    case RigFaultSource::kKinematics:
      return "kinematics";
  }
  return "?";
}

HybridFieldbusDevice::HybridFieldbusDevice(const HybridFieldbusConfig& config, transport::CanPort& drive_1_port,
                                           transport::CanPort& drive_2_port, const fieldbus::Timebase& timebase)
    : config_(config), kinematics_(config.geometry), allocator_(config.allocation) {
  config_.Validate();
  drives_[0] = std::make_unique<fieldbus::Cia402Drive>(config_.drives[0], drive_1_port, timebase);
  drives_[1] = std::make_unique<fieldbus::Cia402Drive>(config_.drives[1], drive_2_port, timebase);
  amplifier_ = std::make_unique<fieldbus::ModbusIoThread>(config_.amplifier);
  const FmeMap map =
      MapForceManipulability(kinematics_, config_.allocation.motor.MaxJointTorqueNm(),
                             config_.allocation.brake.max_torque_Nm * config_.allocation.brake.pulley_ratio, 0.01);
  capabilities_.dof = 2;
  capabilities_.rendering = Rendering::kActiveAndDissipative;
  capabilities_.max_force_N = DofVector::Constant(2, map.min_motor_force_N);
  capabilities_.has_brake = true;
  capabilities_.max_brake_force_N = DofVector::Constant(2, map.min_brake_force_N);
  capabilities_.measures_velocity = true;
  capabilities_.measures_force = true;
}

HybridFieldbusDevice::~HybridFieldbusDevice() { Deactivate(); }

void HybridFieldbusDevice::Configure() {
  for (auto& d : drives_) d->Configure();
  amplifier_->Start();
}

void HybridFieldbusDevice::Activate() {
  for (std::size_t i = 0; i < 2; ++i) {
    try {
      drives_[i]->Activate();
    } catch (const Error& e) {
      throw Error("device.hybrid: drive " + std::to_string(i + 1) + " did not reach Operation Enabled: " + e.what());
    }
  }
  if (!amplifier_->WaitForFirstPoll(1.0)) {
    throw Error("device.hybrid: the brake amplifier did not answer within 1 s (Modbus unit " +
                std::to_string(config_.amplifier.unit_id) + "); check its address, wiring and unit id");
  }
  allocator_.Reset();
  latched_ = false;
  fault_source_ = RigFaultSource::kNone;
  fault_bits_ = kFaultNone;
  active_ = true;
}

void HybridFieldbusDevice::Deactivate() noexcept {
  if (active_) {
    CommandSafe();
    for (auto& d : drives_) (void)d->Deactivate();
  }
  active_ = false;
  if (amplifier_) amplifier_->Stop();
}

void HybridFieldbusDevice::Latch(RigFaultSource source, std::uint32_t bits) noexcept {
  if (!latched_) fault_source_ = source;
  latched_ = true;
  fault_bits_ |= bits;
}

void HybridFieldbusDevice::Read(Reading& out) noexcept {
  out.position_m = DofVector::Zero(2);
  out.velocity_m_per_s = DofVector::Zero(2);
  out.force_N = DofVector::Zero(2);
  out.rendered_force_N = DofVector::Zero(2);
  out.faults = kFaultNone;
  if (!active_) {
    out.faults = kFaultDriver;
    return;
  }
  const double ratio = config_.allocation.motor.pulley_ratio;
  for (std::size_t i = 0; i < 2; ++i) {
    fieldbus::Cia402Reading r;
    const Cia402Status status = drives_[i]->Read(r);
    const RigFaultSource source = i == 0 ? RigFaultSource::kDrive1 : RigFaultSource::kDrive2;
    switch (status) {
      case Cia402Status::kOk:
      case Cia402Status::kNoNewData:
        break;
      case Cia402Status::kStale:
      case Cia402Status::kHeartbeatLost:
      case Cia402Status::kBusOff:
      case Cia402Status::kWriteFailed:
        Latch(source, kFaultCommunication);
        break;
      case Cia402Status::kNotEnabled:
      case Cia402Status::kFault:
      case Cia402Status::kNotActive:
        Latch(source, kFaultDriver);
        break;
    }
    joint_rad_(static_cast<int>(i)) = r.position_rad / ratio + config_.joint_offset_rad[i];
    joint_velocity_rad_per_s_(static_cast<int>(i)) = r.velocity_rad_per_s / ratio;
  }
  fieldbus::ModbusReading m;
  if (amplifier_->LatestReading(m) != kFaultNone) Latch(RigFaultSource::kAmplifier, kFaultCommunication);
  hand_force_N_ = {m.values[0], m.values[1]};
  Eigen::Vector2d p;
  if (!joint_rad_.allFinite() || !kinematics_.Forward(joint_rad_, p) || !kinematics_.Jacobian(joint_rad_, jacobian_)) {
    Latch(RigFaultSource::kKinematics, kFaultOutOfRange);
    out.faults = fault_bits_;
    return;
  }
  if (!kinematics_.InWorkspace(p)) out.faults |= kFaultOutOfRange;
  const Eigen::Vector2d v = jacobian_ * joint_velocity_rad_per_s_;
  out.position_m << p.x() - config_.origin_m.x(), p.y() - config_.origin_m.y();
  out.velocity_m_per_s << v.x(), v.y();
  out.force_N << hand_force_N_.x(), hand_force_N_.y();
  if (!latched_) {
    const Eigen::Vector2d rendered = jacobian_.transpose().fullPivLu().solve(allocation_out_.motor_joint_Nm +
                                                                             allocation_out_.brake_estimate_joint_Nm);
    out.rendered_force_N << rendered.x(), rendered.y();
  }
  if (!out.position_m.allFinite() || !out.velocity_m_per_s.allFinite() || !out.force_N.allFinite()) {
    out.faults |= kFaultNonFiniteSensor;
  }
  if (bad_command_) out.faults |= kFaultDriver;
  out.faults |= fault_bits_;
}

void HybridFieldbusDevice::CommandSafe() noexcept {
  for (const bool producer : {false, true}) {
    for (std::size_t i = 0; i < 2; ++i) {
      if (config_.drives[i].produce_sync == producer) (void)drives_[i]->Write(0.0);
    }
  }
  fieldbus::ModbusCommand c;
  c.values[0] = config_.allocation.brake.max_torque_Nm;
  c.values[1] = config_.allocation.brake.max_torque_Nm;
  amplifier_->PublishCommand(c);
  allocation_out_ = AllocationOutput{};
}

void HybridFieldbusDevice::Write(const Command& command) noexcept {
  bad_command_ = command.force_N.size() != 2 || !command.force_N.allFinite();
  desired_N_ = bad_command_ ? Eigen::Vector2d::Zero() : Eigen::Vector2d(command.force_N(0), command.force_N(1));
  if (!active_ || latched_) {
    if (active_) CommandSafe();
    return;
  }
  AllocationInput in;
  in.jacobian_m_per_rad = jacobian_;
  in.joint_velocity_rad_per_s = joint_velocity_rad_per_s_;
  in.hand_force_N = hand_force_N_.allFinite() ? hand_force_N_ : Eigen::Vector2d::Zero();
  in.desired_force_N = desired_N_;
  allocation_out_ = allocator_.Step(in, period_s_);
  const double ratio = config_.allocation.motor.pulley_ratio;
  // Every RPDO before the SYNC: the drives that do not produce it are written first, so both apply this cycle's
  // torque on the same SYNC.
  for (const bool producer : {false, true}) {
    for (std::size_t i = 0; i < 2; ++i) {
      if (config_.drives[i].produce_sync != producer) continue;
      const Cia402Status s = drives_[i]->Write(allocation_out_.motor_joint_Nm(static_cast<int>(i)) / ratio);
      if (s != Cia402Status::kOk) {
        Latch(i == 0 ? RigFaultSource::kDrive1 : RigFaultSource::kDrive2, kFaultCommunication);
      }
    }
  }
  fieldbus::ModbusCommand c;
  c.values[0] = allocation_out_.brake_shaft_Nm(0);
  c.values[1] = allocation_out_.brake_shaft_Nm(1);
  amplifier_->PublishCommand(c);
}

void HybridFieldbusDevice::Update(double period_s) noexcept {
  if (period_s > 0.0 && std::isfinite(period_s)) period_s_ = period_s;
}

void HybridFieldbusDevice::SetSafe() noexcept {
  if (active_) CommandSafe();
}

}  // namespace teleop::device::hybrid
