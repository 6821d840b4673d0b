#include "device/hybrid/hybrid_fieldbus_device.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "device/hybrid/force_manipulability.hpp"
#include "teleop/error.hpp"

namespace teleop::device::hybrid {

using fieldbus::Cia402Status;

void HybridFieldbusConfig::Validate() const {
  geometry.Validate();
  allocation.Validate();
  fieldbus::Validate(amplifier);
  for (const char* name : {"brake_1_Nm", "brake_2_Nm"}) {
    const int k = fieldbus::FindPoint(amplifier.outputs, name);
    if (k < 0) {
      throw Error(std::string("device.hybrid fieldbus: the amplifier's register map needs an output '") + name +
                  "' (brake shaft torque, N·m)");
    }
    const double safe = amplifier.outputs[static_cast<std::size_t>(k)].safe_value;
    if (std::abs(safe - allocation.brake.max_torque_Nm) > 1e-9) {
      throw Error(std::string("device.hybrid fieldbus: output '") + name + "' needs safe_value " +
                  std::to_string(allocation.brake.max_torque_Nm) +
                  " (brake.max_torque_Nm: the brakes engaged, what the I/O thread writes when the loop stops "
                  "commanding), not " +
                  std::to_string(safe));
    }
  }
  if (force_sensor == ForceSensorBus::kModbus) {
    for (const char* name : {"force_x_N", "force_y_N"}) {
      if (fieldbus::FindPoint(amplifier.inputs, name) < 0) {
        throw Error(std::string("device.hybrid fieldbus: the force sensor is on Modbus, so the register map needs an "
                                "input '") +
                    name + "' (handle force, N, base frame)");
      }
    }
  } else {
    can_force_sensor.Validate("device.hybrid fieldbus: force_sensor");
    if (can_force_sensor.axes != 2) throw Error("device.hybrid fieldbus: force_sensor: axes must be 2 (F_x, F_y)");
  }
  if (drives[0].node_id == drives[1].node_id)
    throw Error("device.hybrid fieldbus: the two drives need different node ids");
  if (drives[0].produce_sync || drives[1].produce_sync) {
    throw Error(
        "device.hybrid fieldbus: produce_sync must be false on both drives (the device sends one SYNC per "
        "cycle for the bus)");
  }
  if (sync_cob_id == 0 || sync_cob_id > 0x7FFu) throw Error("device.hybrid fieldbus: sync_cob_id must be 0x001..0x7FF");
  if (!std::isfinite(joint_offset_rad[0]) || !std::isfinite(joint_offset_rad[1]) || !origin_m.allFinite()) {
    throw Error("device.hybrid fieldbus: joint offsets and origin must be finite");
  }
  if (!(activate_timeout_ms > 0.0) || !std::isfinite(activate_timeout_ms)) {
    throw Error("device.hybrid fieldbus: activate_timeout_ms must be > 0");
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
    case RigFaultSource::kForceSensor:
      return "force sensor";
    case RigFaultSource::kKinematics:
      return "kinematics";
    case RigFaultSource::kSync:
      return "SYNC";
  }
  return "?";
}

HybridFieldbusDevice::HybridFieldbusDevice(const HybridFieldbusConfig& config, transport::CanPort& drive_1_port,
                                           transport::CanPort& drive_2_port, const fieldbus::Timebase& timebase,
                                           transport::CanPort* sensor_port)
    : config_(config), kinematics_(config.geometry), allocator_(config.allocation), timebase_(timebase) {
  config_.Validate();
  if (config_.force_sensor == ForceSensorBus::kCan && sensor_port == nullptr) {
    throw Error("device.hybrid fieldbus: the force sensor is on CAN: give its port");
  }
  ports_ = {&drive_1_port, &drive_2_port, sensor_port};
  SetCapabilities();
  Build();
}

HybridFieldbusDevice::HybridFieldbusDevice(const HybridFieldbusConfig& config, const fieldbus::CanPortConfig& can)
    : config_(config),
      kinematics_(config.geometry),
      allocator_(config.allocation),
      timebase_(fieldbus::Timebase::Steady()),
      can_(can) {
  config_.Validate();
  SetCapabilities();
  amplifier_ = std::make_unique<fieldbus::ModbusIoThread>(config_.amplifier);  // validates, no I/O
}

void HybridFieldbusDevice::SetCapabilities() {
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

void HybridFieldbusDevice::Build() {
  drives_[0] = std::make_unique<fieldbus::Cia402Drive>(config_.drives[0], *ports_[0], timebase_);
  drives_[1] = std::make_unique<fieldbus::Cia402Drive>(config_.drives[1], *ports_[1], timebase_);
  sync_ = std::make_unique<fieldbus::canopen::SyncProducer>(*ports_[0], config_.sync_cob_id);
  if (config_.force_sensor == ForceSensorBus::kCan) {
    sensor_ = std::make_unique<fieldbus::CanForceSensor>(config_.can_force_sensor, *ports_[2], timebase_);
  }
  if (!amplifier_) amplifier_ = std::make_unique<fieldbus::ModbusIoThread>(config_.amplifier);
  for (int i = 0; i < 2; ++i) {
    const auto k = static_cast<std::size_t>(i);
    brake_output_[k] = fieldbus::FindPoint(config_.amplifier.outputs, i == 0 ? "brake_1_Nm" : "brake_2_Nm");
    if (config_.force_sensor == ForceSensorBus::kModbus) {
      force_input_[k] = fieldbus::FindPoint(config_.amplifier.inputs, i == 0 ? "force_x_N" : "force_y_N");
    }
  }
  clutch_input_ = fieldbus::FindPoint(config_.amplifier.inputs, "clutch");
}

HybridFieldbusDevice::~HybridFieldbusDevice() { Deactivate(); }

void HybridFieldbusDevice::Configure() {
  if (can_.has_value() && !drives_[0]) {
    for (std::size_t i = 0; i < 2; ++i) {
      try {
        owned_ports_[i] = fieldbus::OpenCanPort(*can_, fieldbus::Cia402Drive::ReceiveOptions(config_.drives[i]));
      } catch (const Error& e) {
        throw Error("device.hybrid.fieldbus.can: drive " + std::to_string(i + 1) + "'s port: " + e.what());
      }
      ports_[i] = owned_ports_[i].get();
    }
    if (config_.force_sensor == ForceSensorBus::kCan) {
      owned_ports_[2] =
          fieldbus::OpenCanPort(*can_, fieldbus::CanForceSensor::ReceiveOptions(config_.can_force_sensor));
      ports_[2] = owned_ports_[2].get();
    }
    Build();
  }
  for (auto& d : drives_) d->Configure();
  if (!amplifier_->running()) amplifier_->Start();
}

void HybridFieldbusDevice::Activate() {
  for (std::size_t i = 0; i < 2; ++i) {
    try {
      drives_[i]->Activate();
    } catch (const Error& e) {
      throw Error("device.hybrid: drive " + std::to_string(i + 1) + " did not reach Operation Enabled: " + e.what());
    }
  }
  if (!amplifier_->WaitForFirstPoll(config_.activate_timeout_ms * 1e-3)) {
    throw Error("device.hybrid: the brake amplifier did not answer within " +
                std::to_string(static_cast<int>(config_.activate_timeout_ms)) + " ms (Modbus unit " +
                std::to_string(config_.amplifier.unit_id) + "); check its address, wiring and unit id");
  }
  // Prime the cycle (set-up, blocking): SYNCs at the drives' period until both drives have sent a reading in
  // Operation Enabled and the CAN force sensor a valid frame, so the first cycle starts from measured values.
  const double period_ms = config_.drives[0].cycle_period_s * 1e3;
  std::array<bool, 3> seen{false, false, sensor_ == nullptr};
  for (double waited_ms = 0.0; !(seen[0] && seen[1] && seen[2]) && waited_ms <= config_.activate_timeout_ms;
       waited_ms += period_ms) {
    (void)sync_->Send();
    timebase_.wait_ns(static_cast<std::uint64_t>(period_ms * 1e6));
    for (std::size_t i = 0; i < 2; ++i) {
      fieldbus::Cia402Reading r;
      const Cia402Status st = drives_[i]->Read(r);
      if (st == Cia402Status::kOk) seen[i] = true;
      if (st == Cia402Status::kFault || st == Cia402Status::kNotEnabled || st == Cia402Status::kBusOff) {
        throw Error("device.hybrid: drive " + std::to_string(i + 1) + " reported " + fieldbus::ToString(st) +
                    " right after activation");
      }
    }
    if (sensor_) {
      fieldbus::CanForceReading f;
      if (sensor_->Read(f) == fieldbus::CanForceSensorStatus::kOk) seen[2] = true;
    }
  }
  for (std::size_t i = 0; i < 2; ++i) {
    if (!seen[i]) {
      throw Error("device.hybrid: drive " + std::to_string(i + 1) + " sent no TPDO on SYNC within " +
                  std::to_string(static_cast<int>(config_.activate_timeout_ms)) +
                  " ms after Operation Enabled; check its PDO mapping and transmission type (1: on every SYNC)");
    }
  }
  if (!seen[2]) {
    char cob[16];
    std::snprintf(cob, sizeof cob, "0x%03X", static_cast<unsigned>(config_.can_force_sensor.cob_id));
    throw Error(std::string("device.hybrid: the CAN force sensor sent no valid frame on ") + cob + " within " +
                std::to_string(static_cast<int>(config_.activate_timeout_ms)) +
                " ms; check its COB-ID, frame length (axes × encoding) and that it runs");
  }
  first_cycle_ = true;
  awaiting_fresh_ = {true, true, sensor_ != nullptr};
  allocator_.Reset();
  latched_ = false;
  fault_status_.store(Cia402Status::kOk, std::memory_order_relaxed);
  fault_emcy_code_.store(0, std::memory_order_relaxed);
  fault_source_.store(RigFaultSource::kNone, std::memory_order_release);
  fault_bits_ = kFaultNone;
  active_ = true;
}

void HybridFieldbusDevice::Deactivate() noexcept {
  if (active_) {
    CommandSafe();
    if (latched_) {
      spdlog::error(
          "device.hybrid: the {} latched the safe state (faults 0x{:x}): {}; motors at zero torque, brakes "
          "engaged",
          ToString(fault_source()), static_cast<unsigned>(fault_bits_), FaultText());
    }
    for (auto& d : drives_) {
      if (d) (void)d->Deactivate();
    }
  }
  active_ = false;
  if (amplifier_) amplifier_->Stop();
}

void HybridFieldbusDevice::SendCycleSync() noexcept {
  if (sync_->Send() != transport::CanWriteStatus::kOk) Latch(RigFaultSource::kSync, kFaultCommunication);
}

void HybridFieldbusDevice::Latch(RigFaultSource source, std::uint32_t bits, Cia402Status status) noexcept {
  if (!latched_) {
    const bool drive = source == RigFaultSource::kDrive1 || source == RigFaultSource::kDrive2;
    fault_status_.store(status, std::memory_order_relaxed);
    fault_emcy_code_.store(drive && status == Cia402Status::kFault
                               ? drives_[source == RigFaultSource::kDrive1 ? 0 : 1]->last_emergency().error_code
                               : std::uint16_t{0},
                           std::memory_order_relaxed);
    fault_source_.store(source, std::memory_order_release);
  }
  latched_ = true;
  fault_bits_ |= bits;
}

std::string HybridFieldbusDevice::FaultText() const {
  const RigFaultSource source = fault_source_.load(std::memory_order_acquire);
  switch (source) {
    case RigFaultSource::kNone:
      return {};
    case RigFaultSource::kDrive1:
    case RigFaultSource::kDrive2: {
      const std::size_t i = source == RigFaultSource::kDrive1 ? 0 : 1;
      return fmt::format("drive {} (node {}): {}", i + 1, config_.drives[i].node_id,
                         fieldbus::DescribeFault(config_.drives[i], fault_status_.load(std::memory_order_relaxed),
                                                 fault_emcy_code_.load(std::memory_order_relaxed)));
    }
    case RigFaultSource::kAmplifier:
      return "the brake amplifier (Modbus): a failed transaction, or no good poll within its stale_after_ms";
    case RigFaultSource::kForceSensor:
      return fmt::format(
          "the CAN force sensor (COB-ID 0x{:03X}): no frame for its stale_after_ms ({} ms), or "
          "bus-off",
          static_cast<unsigned>(config_.can_force_sensor.cob_id), config_.can_force_sensor.stale_after_ms);
    case RigFaultSource::kKinematics:
      return "the five-bar has no pose at the joint reading (a non-finite or out-of-reach joint angle)";
    case RigFaultSource::kSync:
      return "the bus refused the cycle's SYNC (bus-off or a full transmit queue)";
  }
  return {};
}

bool HybridFieldbusDevice::InGrace(std::uint64_t now_ns) noexcept {
  if (first_cycle_) {
    // Between Activate() and the loop's first cycle the process may have waited (its peer, other set-up): the
    // activation-time readings count as current until the first SYNC of the loop has had time to answer.
    first_cycle_ = false;
    grace_end_ns_ = now_ns + static_cast<std::uint64_t>(
                                 std::max({config_.drives[0].stale_after_ms, config_.drives[1].stale_after_ms,
                                           sensor_ ? config_.can_force_sensor.stale_after_ms : 0.0}) *
                                 1e6);
  }
  return now_ns < grace_end_ns_;
}

void HybridFieldbusDevice::TakeInDrives(bool in_grace) noexcept {
  const double ratio = config_.allocation.motor.pulley_ratio;
  for (std::size_t i = 0; i < 2; ++i) {
    fieldbus::Cia402Reading r;
    Cia402Status status = drives_[i]->Read(r);
    if (status == Cia402Status::kOk) awaiting_fresh_[i] = false;
    if (status == Cia402Status::kStale && awaiting_fresh_[i] && in_grace) status = Cia402Status::kNoNewData;
    const RigFaultSource source = i == 0 ? RigFaultSource::kDrive1 : RigFaultSource::kDrive2;
    switch (status) {
      case Cia402Status::kOk:
      case Cia402Status::kNoNewData:
        break;
      case Cia402Status::kStale:
      case Cia402Status::kHeartbeatLost:
      case Cia402Status::kBusOff:
      case Cia402Status::kWriteFailed:
        Latch(source, kFaultCommunication, status);
        break;
      case Cia402Status::kNotEnabled:
      case Cia402Status::kFault:
      case Cia402Status::kNotActive:
      case Cia402Status::kWrongMode:
        Latch(source, kFaultDriver, status);
        break;
    }
    joint_rad_(static_cast<int>(i)) = r.position_rad / ratio + config_.joint_offset_rad[i];
    joint_velocity_rad_per_s_(static_cast<int>(i)) = r.velocity_rad_per_s / ratio;
  }
}

void HybridFieldbusDevice::TakeInAmplifierAndSensor(bool in_grace) noexcept {
  fieldbus::ModbusReading m;
  if (amplifier_->LatestReading(m) != kFaultNone) Latch(RigFaultSource::kAmplifier, kFaultCommunication);
  // The clutch pedal, when the register map has an input `clutch` (any table; a discrete input, FC 2, is the
  // usual one): pressed while it reads non-zero. A stale amplifier latches the safe state above, pedal or not.
  clutch_pressed_ = clutch_input_ >= 0 && m.values[static_cast<std::size_t>(clutch_input_)] != 0.0;
  if (!sensor_) {
    hand_force_N_ = {m.values[static_cast<std::size_t>(force_input_[0])],
                     m.values[static_cast<std::size_t>(force_input_[1])]};
    return;
  }
  fieldbus::CanForceReading f;
  fieldbus::CanForceSensorStatus s = sensor_->Read(f);
  if (s == fieldbus::CanForceSensorStatus::kOk) awaiting_fresh_[2] = false;
  if (s == fieldbus::CanForceSensorStatus::kStale && awaiting_fresh_[2] && in_grace) {
    s = fieldbus::CanForceSensorStatus::kNoNewData;
  }
  if (s == fieldbus::CanForceSensorStatus::kStale || s == fieldbus::CanForceSensorStatus::kBusOff) {
    Latch(RigFaultSource::kForceSensor, kFaultCommunication);
  }
  hand_force_N_ = {f.force_N[0], f.force_N[1]};
}

void HybridFieldbusDevice::Exchange() noexcept {
  if (!active_) return;
  const bool in_grace = InGrace(timebase_.now_ns());
  TakeInDrives(in_grace);              // TPDOs in: sampled at the previous SYNC
  TakeInAmplifierAndSensor(in_grace);  // the I/O thread's newest poll; the CAN force sensor's frames
  // The cycle's one SYNC, after the TPDOs of the previous one were drained and long after the previous cycle's
  // RPDOs of both drives: they apply those torques on it, together, and sample their next TPDOs.
  SendCycleSync();
}

void HybridFieldbusDevice::Read(Reading& out) noexcept {
  out.position_m = DofVector::Zero(2);
  out.velocity_m_per_s = DofVector::Zero(2);
  out.force_N = DofVector::Zero(2);
  out.rendered_force_N = DofVector::Zero(2);
  out.faults = kFaultNone;
  out.clutch_pressed = false;
  if (!active_) {
    out.faults = kFaultDriver;
    return;
  }
  out.clutch_pressed = clutch_pressed_;
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

void HybridFieldbusDevice::WriteDrives(double torque_1_Nm, double torque_2_Nm) noexcept {
  const double ratio = config_.allocation.motor.pulley_ratio;
  const std::array<double, 2> joint_Nm{torque_1_Nm, torque_2_Nm};
  for (std::size_t i = 0; i < 2; ++i) {
    if (const Cia402Status s = drives_[i]->WriteTorque_Nm(joint_Nm[i] / ratio); s != Cia402Status::kOk) {
      Latch(i == 0 ? RigFaultSource::kDrive1 : RigFaultSource::kDrive2, kFaultCommunication, s);
    }
  }
}

void HybridFieldbusDevice::CommandSafe() noexcept {
  WriteDrives(0.0, 0.0);
  fieldbus::ModbusCommand c;
  c.values[static_cast<std::size_t>(brake_output_[0])] = config_.allocation.brake.max_torque_Nm;
  c.values[static_cast<std::size_t>(brake_output_[1])] = config_.allocation.brake.max_torque_Nm;
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
  // Both RPDOs now, a period ahead of the SYNC that applies them: the next cycle's Exchange().
  WriteDrives(allocation_out_.motor_joint_Nm(0), allocation_out_.motor_joint_Nm(1));
  fieldbus::ModbusCommand c;
  c.values[static_cast<std::size_t>(brake_output_[0])] = allocation_out_.brake_shaft_Nm(0);
  c.values[static_cast<std::size_t>(brake_output_[1])] = allocation_out_.brake_shaft_Nm(1);
  amplifier_->PublishCommand(c);
}

void HybridFieldbusDevice::Update(double period_s) noexcept {
  if (period_s > 0.0 && std::isfinite(period_s)) period_s_ = period_s;
}

void HybridFieldbusDevice::SetSafe() noexcept {
  if (active_) CommandSafe();
}

}  // namespace teleop::device::hybrid
