#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "teleop/device/device.hpp"
#include "teleop/device/hybrid/five_bar.hpp"
#include "teleop/device/hybrid/motor_brake_allocation.hpp"
#include "teleop/fieldbus/cia402_drive.hpp"
#include "teleop/fieldbus/modbus_io_thread.hpp"

namespace teleop::device::hybrid {

/// The real rig's driver: two CiA 402 drives in cyclic synchronous torque mode (one per active joint, motor and
/// encoder behind the reducer, the joint 1/pulley_ratio of the drive's shaft angle), a Modbus brake amplifier
/// (outputs 0 and 1: brake 1 and 2 shaft torque in N·m; the register map, scaling and unit id are the
/// ModbusConfig's) and the handle force sensor read through the same Modbus I/O thread (inputs 0 and 1: F_x, F_y in
/// N, base frame).
struct HybridFieldbusConfig {
  FiveBarConfig geometry{};
  AllocationConfig allocation{};  ///< Motor and brake limits, pulley ratios, rest threshold.
  std::array<fieldbus::Cia402DriveConfig, 2> drives{};
  /// Joint angle (rad) when the drive's position actual is 0 (homing offset), per joint.
  std::array<double, 2> joint_offset_rad{0.0, 0.0};
  fieldbus::ModbusConfig amplifier{};
  /// Readings are relative to this handle position (base frame, m), like the simulated backend.
  Eigen::Vector2d origin_m{0.0, 0.200};
  void Validate() const;  ///< teleop::Error: geometry, allocation, register map (≥ 2 outputs, ≥ 2 inputs).
};

/// Which part put the device into its latched safe state (Reading::faults carries the bits).
enum class RigFaultSource : std::uint8_t { kNone, kDrive1, kDrive2, kAmplifier, kKinematics };
const char* ToString(RigFaultSource source) noexcept;

/// Device lifecycle: the constructor validates and builds the clients on the given CAN ports (which must outlive the
/// device and receive Cia402Drive::ReceiveOptions of their drive); Configure() configures both drives (SDO set-up,
/// PDO mapping) and starts the Modbus I/O thread; Activate() brings both drives to Operation Enabled and waits for
/// the amplifier's first poll (teleop::Error naming the part otherwise).
///
/// Safe state (latched, until Activate() again): a drive that leaves Operation Enabled, faults, goes stale or loses
/// its heartbeat, or an amplifier that stops answering (stale reading), puts the motors to zero torque and commands
/// the brakes fully engaged (a brake can only stop motion). Modbus outputs' safe_value should also be the engaged
/// torque, so the I/O thread's own command timeout lands in the same state.
class HybridFieldbusDevice final : public Device {
 public:
  HybridFieldbusDevice(const HybridFieldbusConfig& config, transport::CanPort& drive_1_port,
                       transport::CanPort& drive_2_port,
                       const fieldbus::Timebase& timebase = fieldbus::Timebase::Steady());
  ~HybridFieldbusDevice() override;

  const Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override { return name_; }
  void Configure() override;
  void Activate() override;
  void Deactivate() noexcept override;
  void Read(Reading& out) noexcept override;
  void Write(const Command& command) noexcept override;
  void Update(double period_s) noexcept override;
  void SetSafe() noexcept override;

  bool latched_safe() const noexcept { return latched_; }
  RigFaultSource fault_source() const noexcept { return fault_source_; }
  std::uint32_t fault_bits() const noexcept { return fault_bits_; }
  const fieldbus::Cia402Drive& drive(int i) const noexcept { return *drives_[static_cast<std::size_t>(i)]; }
  const fieldbus::ModbusIoThread& amplifier() const noexcept { return *amplifier_; }
  const AllocationOutput& last_allocation() const noexcept { return allocation_out_; }

 private:
  void Latch(RigFaultSource source, std::uint32_t bits) noexcept;
  void CommandSafe() noexcept;

  HybridFieldbusConfig config_;
  Capabilities capabilities_;
  std::string name_ = "hybrid";
  FiveBar kinematics_;
  MotorBrakeAllocator allocator_;
  std::array<std::unique_ptr<fieldbus::Cia402Drive>, 2> drives_;
  std::unique_ptr<fieldbus::ModbusIoThread> amplifier_;
  Eigen::Vector2d joint_rad_{0.0, 0.0};
  Eigen::Vector2d joint_velocity_rad_per_s_{0.0, 0.0};
  Eigen::Vector2d hand_force_N_{0.0, 0.0};
  Eigen::Matrix2d jacobian_ = Eigen::Matrix2d::Identity();
  Eigen::Vector2d desired_N_{0.0, 0.0};
  AllocationOutput allocation_out_{};
  bool active_ = false;
  bool latched_ = false;
  bool bad_command_ = false;
  RigFaultSource fault_source_ = RigFaultSource::kNone;
  std::uint32_t fault_bits_ = kFaultNone;
  double period_s_ = 1e-3;
};

}  // namespace teleop::device::hybrid
