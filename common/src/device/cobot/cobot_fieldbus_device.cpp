#include "device/cobot/cobot_fieldbus_device.hpp"

#include <fmt/format.h>

#include <cmath>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::cobot {

namespace {

VirtualWallConfig ControllerConfig(const CobotBackendConfig& c) {
  if (c.kind != CobotBackendConfig::Kind::kUnicycle) {
    throw Error(
        "device.cobot: the fieldbus rig is a unicycle cobot (one steering drive); kind bicycle is simulated only");
  }
  VirtualWallConfig w = c.unicycle.controller;
  if (c.unicycle.derive_time_constant) {
    w.steering_time_constant_s = SteeringTimeConstant_s(c.unicycle.plant, w.tracker.k2_Nms_per_rad);
  }
  Validate(w);
  Validate(c.fieldbus.sensors);
  if (c.fieldbus.sensors.node_id == c.fieldbus.steering.drive.node_id) {
    throw Error("device.cobot.fieldbus: the sensor node and the steering drive need different node ids (both " +
                std::to_string(c.fieldbus.steering.drive.node_id) + ")");
  }
  return w;
}

std::uint32_t FaultBits(SteeringFault f) noexcept {
  switch (f) {
    case SteeringFault::kNone:
      return kFaultNone;
    case SteeringFault::kDriveLost:
    case SteeringFault::kHeartbeatLost:
      return kFaultCommunication;
    case SteeringFault::kDriveFault:
    case SteeringFault::kEncoderJump:
      return kFaultDriver;
  }
  return kFaultDriver;
}

std::uint32_t FaultBits(SensorFault f) noexcept {
  switch (f) {
    case SensorFault::kNone:
      return kFaultNone;
    case SensorFault::kLost:
    case SensorFault::kBusError:
      return kFaultCommunication;
    case SensorFault::kWheelJump:
    case SensorFault::kBadFrame:
      return kFaultDriver;
    case SensorFault::kForceInvalid:
      return kFaultNonFiniteSensor;
  }
  return kFaultDriver;
}

}  // namespace

UnicycleCobotFieldbusDevice::UnicycleCobotFieldbusDevice(const CobotBackendConfig& config, fieldbus::Timebase timebase)
    : config_(config),
      timebase_(std::move(timebase)),
      capabilities_(CobotCapabilities(2, config.unicycle.plant.brake_max_force_N)),
      controller_(ControllerConfig(config), Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true)),
      walls_(config.contact_force_threshold_N),
      speed_estimator_(config.unicycle.speed_filter),
      rate_estimator_(config.unicycle.steering_rate_filter) {
  controller_.SetWallActive(false);
}

UnicycleCobotFieldbusDevice::UnicycleCobotFieldbusDevice(const CobotBackendConfig& config,
                                                         transport::CanPort& drive_port,
                                                         transport::CanPort& sensor_port,
                                                         transport::CanPort& force_port, fieldbus::Timebase timebase)
    : UnicycleCobotFieldbusDevice(config, std::move(timebase)) {
  Build(drive_port, sensor_port, force_port);
}

UnicycleCobotFieldbusDevice::~UnicycleCobotFieldbusDevice() { Deactivate(); }

void UnicycleCobotFieldbusDevice::Build(transport::CanPort& drive_port, transport::CanPort& sensor_port,
                                        transport::CanPort& force_port) {
  steering_ = std::make_unique<CobotSteeringDrive>(config_.fieldbus.steering, drive_port, timebase_);
  sensors_ = std::make_unique<CobotSensorNode>(config_.fieldbus.sensors, sensor_port, timebase_);
  force_ =
      std::make_unique<fieldbus::CanForceSensor>(config_.fieldbus.sensors.ForceSensorConfig(), force_port, timebase_);
}

void UnicycleCobotFieldbusDevice::Configure() {
  if (!steering_) {
    const CobotFieldbusConfig& f = config_.fieldbus;
    owned_drive_port_ = fieldbus::OpenCanPort(f.can, fieldbus::Cia402Drive::ReceiveOptions(f.steering.drive));
    owned_sensor_port_ = fieldbus::OpenCanPort(f.can, CobotSensorNode::ReceiveOptions(f.sensors));
    owned_force_port_ =
        fieldbus::OpenCanPort(f.can, fieldbus::CanForceSensor::ReceiveOptions(f.sensors.ForceSensorConfig()));
    Build(*owned_drive_port_, *owned_sensor_port_, *owned_force_port_);
  }
  try {
    steering_->Configure();
  } catch (const Error& e) {
    throw Error("device.cobot: steering drive (node " + std::to_string(config_.fieldbus.steering.drive.node_id) +
                "): " + e.what());
  }
}

void UnicycleCobotFieldbusDevice::Activate() {
  if (!steering_) throw Error("device.cobot: Activate() before Configure()");
  try {
    steering_->Activate();
  } catch (const Error& e) {
    throw Error("device.cobot: steering drive (node " + std::to_string(config_.fieldbus.steering.drive.node_id) +
                ") did not reach Operation Enabled: " + e.what());
  }
  sensors_->Reset();
  // Zero torque cycles (each Write also sends the SYNC the sensor node answers) until both have spoken.
  const double period_s = config_.fieldbus.steering.drive.cycle_period_s;
  const auto period_ns = static_cast<std::uint64_t>(period_s * 1e9);
  const int cycles = static_cast<int>(std::ceil(config_.fieldbus.first_frames_timeout_ms * 1e-3 / period_s));
  SteeringSample s;
  SensorSample m;
  fieldbus::CanForceReading force;
  bool steering_seen = false;
  bool force_seen = false;
  for (int k = 0; k < cycles && !(steering_seen && m.started && force_seen); ++k) {
    (void)steering_->Write(0.0);
    timebase_.wait_ns(period_ns);
    if (steering_->Read(s) != SteeringFault::kNone) {
      throw Error(std::string("device.cobot: steering drive fault at activation: ") + ToString(s.fault));
    }
    steering_seen = steering_seen || s.fresh;
    (void)sensors_->Read(m);
    force_seen = force_->Read(force) == fieldbus::CanForceSensorStatus::kOk || force_seen;
  }
  if (!steering_seen) throw Error("device.cobot: no position from the steering drive after activation");
  if (!m.started || !force_seen) {
    throw Error(
        "device.cobot: the sensor node (node " + std::to_string(config_.fieldbus.sensors.node_id) + ") sent no " +
        (m.started ? "force" : "wheel") + " TPDO (COB-ID " +
        std::to_string(m.started ? config_.fieldbus.sensors.ForceCobId() : config_.fieldbus.sensors.WheelCobId()) +
        ") within " + std::to_string(static_cast<int>(config_.fieldbus.first_frames_timeout_ms)) +
        " ms of the SYNCs; check its node id, its PDO mapping and that it is operational");
  }
  if (m.fault != SensorFault::kNone) {
    throw Error(std::string("device.cobot: sensor node fault at activation: ") + ToString(m.fault));
  }
  heading_rad_ = config_.fieldbus.steering_offset_rad + s.angle_rad;
  travel_m_ = m.wheel_travel_m;
  position_m_ = config_.initial.position_m;
  const double r = config_.unicycle.sensors.wheel_radius_m;
  speed_estimator_.Reset(travel_m_ / r);
  rate_estimator_.Reset(heading_rad_);
  input_ = WallControllerInput{};
  input_.position_m = position_m_;
  input_.steering_angle_rad = heading_rad_;
  controller_.SetWallActive(false);
  walls_ = MasterWalls(config_.contact_force_threshold_N);
  force_fault_ = SensorFault::kNone;
  force_N_ = Vec2::Zero();
  pending_faults_ = kFaultNone;
  stability_warning_ = false;
  first_steering_fault_.store(SteeringFault::kNone, std::memory_order_relaxed);
  first_sensor_fault_.store(SensorFault::kNone, std::memory_order_relaxed);
  safe_ = false;
  active_ = true;
}

std::string UnicycleCobotFieldbusDevice::FaultText() const {
  const fieldbus::Cia402DriveConfig& d = config_.fieldbus.steering.drive;
  const CobotSensorNodeConfig& n = config_.fieldbus.sensors;
  std::string steering;
  switch (first_steering_fault_.load(std::memory_order_relaxed)) {
    case SteeringFault::kNone:
      break;
    case SteeringFault::kDriveLost:
      steering = fmt::format("stopped answering (no TPDO for stale_after_ms, {} ms)", d.stale_after_ms);
      break;
    case SteeringFault::kHeartbeatLost:
      steering = fmt::format("lost its heartbeat (heartbeat_timeout_ms, {} ms)", d.heartbeat_timeout_ms);
      break;
    case SteeringFault::kDriveFault:
      steering = "is in Fault or left Operation Enabled";
      break;
    case SteeringFault::kEncoderJump:
      steering = fmt::format("reported a steering angle jump beyond max_angle_jump_rad ({} rad): held where it is",
                             config_.fieldbus.steering.max_angle_jump_rad);
      break;
  }
  std::string sensor;
  switch (first_sensor_fault_.load(std::memory_order_relaxed)) {
    case SensorFault::kNone:
      break;
    case SensorFault::kLost:
      sensor = fmt::format("stopped sending (no wheel or force frame for stale_after_ms, {} ms)", n.stale_after_ms);
      break;
    case SensorFault::kWheelJump:
      sensor = fmt::format("reported a wheel travel step beyond max_wheel_step_m ({} m)", n.max_wheel_step_m);
      break;
    case SensorFault::kBadFrame:
      sensor = "sent a malformed frame";
      break;
    case SensorFault::kBusError:
      sensor = "is on a bus that reported a CAN error frame";
      break;
    case SensorFault::kForceInvalid:
      sensor = fmt::format("reported no valid handle force (COB-ID 0x{:03X})", n.ForceCobId());
      break;
  }
  std::string text;
  if (!steering.empty()) text = fmt::format("the steering drive (node {}) {}", d.node_id, steering);
  if (!sensor.empty()) {
    text += fmt::format("{}the sensor node (node {}) {}", text.empty() ? "" : "; ", n.node_id, sensor);
  }
  return text;
}

void UnicycleCobotFieldbusDevice::Deactivate() noexcept {
  if (!active_) return;
  SendCycle(0.0, true);
  steering_->Deactivate();
  active_ = false;
}

bool UnicycleCobotFieldbusDevice::locked() const noexcept {
  return safe_ || (steering_ && steering_->locked()) || sensor_fault() != SensorFault::kNone;
}

SteeringFault UnicycleCobotFieldbusDevice::steering_fault() const noexcept {
  return steering_ ? steering_->fault() : SteeringFault::kNone;
}

SensorFault UnicycleCobotFieldbusDevice::sensor_fault() const noexcept {
  if (sensors_ && sensors_->fault() != SensorFault::kNone) return sensors_->fault();
  return force_fault_;
}

void UnicycleCobotFieldbusDevice::Read(Reading& out) noexcept {
  out.position_m = DofVector::Zero(2);
  out.velocity_m_per_s = DofVector::Zero(2);
  out.force_N = DofVector::Zero(2);
  out.rendered_force_N = DofVector::Zero(2);
  if (!active_) {
    out.faults = kFaultDriver;
    return;
  }
  SteeringSample s;
  SensorSample m;
  const SteeringFault steering = steering_->Read(s);
  (void)sensors_->Read(m);
  fieldbus::CanForceReading force;
  switch (force_->Read(force)) {
    case fieldbus::CanForceSensorStatus::kOk:
    case fieldbus::CanForceSensorStatus::kNoNewData:
      if (!std::isfinite(force.force_N[0]) || !std::isfinite(force.force_N[1])) {
        if (force_fault_ == SensorFault::kNone) force_fault_ = SensorFault::kForceInvalid;
      } else if (force_fault_ == SensorFault::kNone) {
        force_N_ = {force.force_N[0], force.force_N[1]};
      }
      break;
    case fieldbus::CanForceSensorStatus::kStale:
    case fieldbus::CanForceSensorStatus::kBusOff:
      if (force_fault_ == SensorFault::kNone) force_fault_ = SensorFault::kLost;
      break;
  }
  if (force_fault_ != SensorFault::kNone) force_N_ = Vec2::Zero();
  const SensorFault sensor = sensor_fault();
  if (steering != SteeringFault::kNone &&
      first_steering_fault_.load(std::memory_order_relaxed) == SteeringFault::kNone) {
    first_steering_fault_.store(steering, std::memory_order_relaxed);
  }
  if (sensor != SensorFault::kNone && first_sensor_fault_.load(std::memory_order_relaxed) == SensorFault::kNone) {
    first_sensor_fault_.store(sensor, std::memory_order_relaxed);
  }
  const double heading = config_.fieldbus.steering_offset_rad + s.angle_rad;
  // Odometry: the wheel rolls along its heading (no lateral slip), at the mid-cycle heading.
  const double ds = m.wheel_travel_m - travel_m_;
  position_m_ += ds * UnitAt(0.5 * (heading + heading_rad_));
  heading_rad_ = heading;
  travel_m_ = m.wheel_travel_m;
  const double r = config_.unicycle.sensors.wheel_radius_m;
  input_.position_m = position_m_;
  input_.steering_angle_rad = heading;
  input_.speed_m_per_s = speed_estimator_.Step(travel_m_ / r, period_s_) * r;
  input_.steering_rate_rad_per_s = rate_estimator_.Step(heading, period_s_);
  input_.handle_force_N = force_N_;
  const Vec2 velocity = input_.speed_m_per_s * UnitAt(heading);
  // The floor's reaction to the operator's push across the wheel (quasi-static: the cart's lateral inertia is
  // not measured): what the constraint renders.
  const Vec2 n = LeftNormal(UnitAt(heading));
  const Vec2 rendered = -force_N_.dot(n) * n;
  out.position_m << position_m_.x(), position_m_.y();
  out.velocity_m_per_s << velocity.x(), velocity.y();
  out.force_N << force_N_.x(), force_N_.y();
  out.rendered_force_N << rendered.x(), rendered.y();
  out.faults = FaultBits(steering) | FaultBits(sensor) | pending_faults_;
  pending_faults_ = kFaultNone;
  out.warnings = stability_warning_ ? kWarningStabilityGuard : kWarningNone;
  if (!out.position_m.allFinite() || !out.velocity_m_per_s.allFinite() || !out.force_N.allFinite()) {
    out.faults |= kFaultNonFiniteSensor;
  }
}

void UnicycleCobotFieldbusDevice::SendCycle(double steering_torque_Nm, bool brake) noexcept {
  brake_engaged_ = brake && config_.fieldbus.sensors.has_brake;
  (void)sensors_->WriteBrake(brake_engaged_);
  (void)steering_->Write(steering_torque_Nm);  // RPDO, then the SYNC; a fault latches in the client
}

void UnicycleCobotFieldbusDevice::Write(const Command& command) noexcept {
  if (!active_) return;
  if (!CobotCommandUsable(command, 2)) {
    pending_faults_ |= kFaultDriver;
    safe_ = true;
  } else {
    safe_ = false;
    walls_.Apply(command, position_m_, input_.speed_m_per_s * UnitAt(heading_rad_), controller_);
  }
  const double hold_Nm = -config_.unicycle.controller.tracker.k2_Nms_per_rad * input_.steering_rate_rad_per_s;
  if (locked()) {
    stability_warning_ = false;
    SendCycle(hold_Nm, true);
    return;
  }
  const WallControllerOutput out = controller_.Step(input_, period_s_);
  stability_warning_ = out.stability.warning;
  SendCycle(out.steering_torque_Nm, out.brake_command > 0.5);
}

void UnicycleCobotFieldbusDevice::Update(double period_s) noexcept {
  if (period_s > 0.0 && std::isfinite(period_s)) {
    period_s_ = period_s;
  } else {
    pending_faults_ |= kFaultDriver;
  }
}

void UnicycleCobotFieldbusDevice::SetSafe() noexcept {
  safe_ = true;
  if (active_) {
    SendCycle(-config_.unicycle.controller.tracker.k2_Nms_per_rad * input_.steering_rate_rad_per_s, true);
  }
}

}  // namespace teleop::device::cobot
