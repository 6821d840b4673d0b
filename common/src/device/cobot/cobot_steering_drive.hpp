#pragma once

#include <cstdint>

#include "teleop/fieldbus/cia402_drive.hpp"

namespace teleop::device::cobot {

/// The cobot's steering motor on a CiA 402 drive (cyclic synchronous torque, teleop::fieldbus::Cia402Drive): the
/// steering angle and rate from the drive's TPDOs (position and velocity actual, through the gear), the steering
/// torque to its RPDO. It watches for the faults after which the steering can no longer be trusted and then locks
/// the steering, latched until Activate():
///  - a lost drive (no TPDO for the client's stale_after_ms, bus-off, a refused frame, not active): the drive can no
///    longer be commanded; the client sends zero torque, so nothing turns the wheel, and brake_requested() asks for
///    the wheel brake where the rig has one;
///  - a heartbeat timeout, or the drive in Fault / out of Operation Enabled: the same;
///  - an encoder jump (the steering angle moves more than max_angle_jump_rad in one cycle): the drive still obeys,
///    so a PD on the drive's torque holds the encoder at its first reading after the jump — a counting error does
///    not move the wheel, which stays on its current tangent (the wall's, when tracking) — and the brake is
///    requested too. lock_angle_rad() is the last trusted angle.
/// The steering axis only: the wheel encoder and the handle force sensor are on CobotSensorNode.
struct CobotSteeringDriveConfig {
  fieldbus::Cia402DriveConfig drive{};
  double gear_ratio = 1.0;                 ///< Motor radians per steering radian.
  double max_angle_jump_rad = 0.2;         ///< Steering angle change per cycle beyond which the encoder is suspect.
  double hold_stiffness_Nm_per_rad = 2.0;  ///< Lock after an encoder jump: Γ = k·(ψ_lock − ψ) − d·ψ̇ (motor side).
  double hold_damping_Nms_per_rad = 0.05;
};

enum class SteeringFault : std::uint8_t { kNone, kDriveLost, kHeartbeatLost, kDriveFault, kEncoderJump };
const char* ToString(SteeringFault fault) noexcept;

struct SteeringSample {
  double angle_rad = 0.0;  ///< Steering angle (joint side).
  double rate_rad_per_s = 0.0;
  bool fresh = false;
  SteeringFault fault = SteeringFault::kNone;  ///< The latched fault, if any.
};

class CobotSteeringDrive {
 public:
  /// Validates (throws teleop::Error); `port` must outlive it and get Cia402Drive::ReceiveOptions(config.drive).
  CobotSteeringDrive(const CobotSteeringDriveConfig& config, transport::CanPort& port,
                     fieldbus::Timebase timebase = fieldbus::Timebase::Steady());
  /// Set-up (throw teleop::Error): the drive's configure and activate; Activate also clears a latched fault.
  void Configure();
  void Activate();
  void Deactivate() noexcept;

  /// Cycle: the newest steering sample; detects and latches faults. No allocation.
  [[nodiscard]] SteeringFault Read(SteeringSample& out) noexcept;
  /// Cycle: the controller's steering torque (N·m at the steering axis), replaced by the lock once a fault is
  /// latched. No allocation.
  [[nodiscard]] SteeringFault Write(double steering_torque_Nm) noexcept;

  bool locked() const noexcept { return fault_ != SteeringFault::kNone; }
  bool brake_requested() const noexcept { return locked(); }
  double lock_angle_rad() const noexcept { return lock_angle_rad_; }
  SteeringFault fault() const noexcept { return fault_; }
  const fieldbus::Cia402Drive& drive() const noexcept { return drive_; }

 private:
  void Latch(SteeringFault fault) noexcept;

  CobotSteeringDriveConfig config_;
  fieldbus::Cia402Drive drive_;
  SteeringFault fault_ = SteeringFault::kNone;
  bool have_sample_ = false;
  double last_angle_rad_ = 0.0;
  double last_rate_rad_per_s_ = 0.0;
  double lock_angle_rad_ = 0.0;      ///< The last trusted steering angle when the fault latched.
  double hold_reference_rad_ = 0.0;  ///< Encoder jump: the first reading after the jump, held.
  double encoder_angle_rad_ = 0.0;   ///< The newest finite reading.
};

}  // namespace teleop::device::cobot
