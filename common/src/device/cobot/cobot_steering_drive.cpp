#include "device/cobot/cobot_steering_drive.hpp"

#include <cmath>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::cobot {

using fieldbus::Cia402Status;

const char* ToString(SteeringFault fault) noexcept {
  switch (fault) {
    case SteeringFault::kNone:
      return "none";
    case SteeringFault::kDriveLost:
      return "drive lost";
    case SteeringFault::kHeartbeatLost:
      return "heartbeat timeout";
    case SteeringFault::kDriveFault:
      return "drive fault";
    case SteeringFault::kEncoderJump:
      return "encoder jump";
  }
  return "?";
}

namespace {
const CobotSteeringDriveConfig& Checked(const CobotSteeringDriveConfig& c) {
  auto positive = [](double v, const char* name) {
    if (!std::isfinite(v) || v <= 0.0) {
      throw Error(std::string("cobot steering drive: ") + name + " must be > 0 (got " + std::to_string(v) + ")");
    }
  };
  positive(c.gear_ratio, "gear_ratio");
  positive(c.max_angle_jump_rad, "max_angle_jump_rad");
  positive(c.hold_stiffness_Nm_per_rad, "hold_stiffness_Nm_per_rad");
  if (!std::isfinite(c.hold_damping_Nms_per_rad) || c.hold_damping_Nms_per_rad < 0.0) {
    throw Error("cobot steering drive: hold_damping_Nms_per_rad must be >= 0");
  }
  return c;
}

SteeringFault FaultOf(Cia402Status status) noexcept {
  switch (status) {
    case Cia402Status::kOk:
    case Cia402Status::kNoNewData:
      return SteeringFault::kNone;
    case Cia402Status::kHeartbeatLost:
      return SteeringFault::kHeartbeatLost;
    case Cia402Status::kFault:
    case Cia402Status::kNotEnabled:
    case Cia402Status::kWrongMode:
      return SteeringFault::kDriveFault;
    case Cia402Status::kStale:
    case Cia402Status::kBusOff:
    case Cia402Status::kWriteFailed:
    case Cia402Status::kNotActive:
      return SteeringFault::kDriveLost;
  }
  return SteeringFault::kDriveLost;
}
}  // namespace

CobotSteeringDrive::CobotSteeringDrive(const CobotSteeringDriveConfig& config, transport::CanPort& port,
                                       fieldbus::Timebase timebase)
    : config_(Checked(config)), drive_(config.drive, port, std::move(timebase)) {}

void CobotSteeringDrive::Configure() { drive_.Configure(); }

void CobotSteeringDrive::Activate() {
  drive_.Activate();
  fault_ = SteeringFault::kNone;
  have_sample_ = false;
}

void CobotSteeringDrive::Deactivate() noexcept { (void)drive_.Deactivate(); }

void CobotSteeringDrive::Latch(SteeringFault fault) noexcept {
  if (fault_ == SteeringFault::kNone && fault != SteeringFault::kNone) {
    fault_ = fault;
    lock_angle_rad_ = last_angle_rad_;  // the last good sample: the tangent the wheel was on
  }
}

SteeringFault CobotSteeringDrive::Read(SteeringSample& out) noexcept {
  fieldbus::Cia402Reading r;
  const Cia402Status status = drive_.Read(r);
  Latch(FaultOf(status));
  if (r.fresh && (status == Cia402Status::kOk || status == Cia402Status::kNoNewData)) {
    const double angle = r.position_rad / config_.gear_ratio;
    const double rate = r.velocity_rad_per_s / config_.gear_ratio;
    const bool finite = std::isfinite(angle) && std::isfinite(rate);
    if (fault_ == SteeringFault::kNone &&
        (!finite || (have_sample_ && std::abs(angle - last_angle_rad_) > config_.max_angle_jump_rad))) {
      Latch(SteeringFault::kEncoderJump);  // lock_angle_rad_ keeps the last trusted angle
      hold_reference_rad_ = finite ? angle : last_angle_rad_;
    }
    if (finite) {
      encoder_angle_rad_ = angle;
      last_rate_rad_per_s_ = rate;
      if (fault_ == SteeringFault::kNone) {
        last_angle_rad_ = angle;
        have_sample_ = true;
      }
    }
  }
  out.angle_rad = fault_ == SteeringFault::kNone ? last_angle_rad_ : lock_angle_rad_;
  out.rate_rad_per_s = last_rate_rad_per_s_;
  out.fresh = r.fresh;
  out.fault = fault_;
  return fault_;
}

SteeringFault CobotSteeringDrive::Write(double steering_torque_Nm) noexcept {
  double motor_torque = steering_torque_Nm / config_.gear_ratio;
  if (fault_ == SteeringFault::kEncoderJump) {
    // The drive obeys but its angle cannot be trusted for control: hold the encoder at its first reading after the
    // jump. A counting error then does not move the wheel (the offset is in the reference too), and a real knock
    // is not driven back on an angle we no longer trust.
    motor_torque = (config_.hold_stiffness_Nm_per_rad * (hold_reference_rad_ - encoder_angle_rad_) -
                    config_.hold_damping_Nms_per_rad * last_rate_rad_per_s_) /
                   config_.gear_ratio;
  } else if (fault_ != SteeringFault::kNone) {
    motor_torque = 0.0;  // the client sends 0 anyway once it has seen the fault
  }
  Latch(FaultOf(drive_.WriteTorque_Nm(motor_torque)));
  return fault_;
}

}  // namespace teleop::device::cobot
