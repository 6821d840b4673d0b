#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "device/hybrid/friction_display.hpp"
#include "device/hybrid/hybrid_fieldbus_device.hpp"
#include "device/hybrid/hybrid_rig.hpp"
#include "device/hybrid/motor_brake_allocation.hpp"
#include "device/hybrid/operator_hand.hpp"
#include "device/hybrid/wall_model.hpp"
#include "teleop/device/device.hpp"

namespace teleop::device::hybrid {

/// A local haptic effect the device renders on top of the loop's command, through the allocation.
struct HybridEffectConfig {
  enum class Kind : std::uint8_t { kNone, kWall, kFriction };
  Kind kind = Kind::kNone;
  WallConfig wall{};
  FrictionConfig friction{};
};

/// A simulated environment touching the handle (slave role): a spring–damper wall that only pushes, occupying
/// (p − point)·n ≥ 0, felt by the handle force sensor.
struct HybridEnvironmentConfig {
  bool wall = false;
  Eigen::Vector2d point_m{0.0, 0.250};
  Eigen::Vector2d normal{0.0, 1.0};
  double stiffness_N_per_m = 2000.0;
  double damping_Ns_per_m = 0.0;
};

/// `device.hybrid`: the simulated hybrid rig as a 2-DOF backend (docs/hybrid.md, docs/configuration.md).
/// Reading::position_m is the handle position relative to rig.initial_position_m (base frame axes), so a process
/// starts at zero like the loopback plant; effect/environment points are in the base frame.
struct HybridDeviceConfig {
  HybridRigConfig rig{};
  AllocationConfig allocation{};  ///< motor/brake are copied from rig (one source of truth).
  HybridEffectConfig effect{};
  bool simulated_operator = false;  ///< Master: a simulated hand (operator) pushes the handle.
  OperatorHandConfig hand{};        ///< hand.start_m is set to rig.initial_position_m.
  double hand_mass_kg = 0.0;        ///< Added to the handle mass.
  HybridEnvironmentConfig environment{};
  /// `rig: fieldbus`: the real rig (HybridFieldbusDevice) instead of the simulated one; geometry, motor, brake,
  /// allocation and initial_position_m (its origin) are shared, the simulation's own keys unused.
  bool fieldbus_rig = false;
  HybridFieldbusRigConfig fieldbus{};
  void Validate() const;  ///< teleop::Error naming the bad field.
};

/// The Device: Read → (law) → Write(Command) → Update. Write renders command.force_N (law + fixture, so also the
/// master-side forbidden-region fixture) plus the local effect through MotorBrakeAllocator; Update integrates the
/// rig. SetSafe: motors to zero torque, brakes fully engaged (a brake can only stop motion).
class HybridDevice final : public Device {
 public:
  explicit HybridDevice(const HybridDeviceConfig& config);

  const Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override { return name_; }
  void Read(Reading& out) noexcept override;
  void Write(const Command& command) noexcept override;
  void Update(double period_s) noexcept override;
  void SetSafe() noexcept override;

  const HybridRig& rig() const noexcept { return rig_; }
  const Eigen::Vector2d& sensed_force_N() const noexcept { return sensed_force_N_; }
  const AllocationOutput& last_allocation() const noexcept { return allocation_out_; }
  const WallModel& wall() const noexcept { return wall_; }
  double time_s() const noexcept { return time_s_; }

 private:
  HybridDeviceConfig config_;
  Capabilities capabilities_;
  std::string name_ = "hybrid";
  void Sense() noexcept;

  HybridRig rig_;
  MotorBrakeAllocator allocator_;
  WallModel wall_;
  OperatorHand hand_;
  // What the device's sensors report (rig.encoders, rig.force_sensor_dynamics), sampled at the end of Update: Read
  // reports them and the next Update's allocation and effects use them.
  JointEncoders encoders_;
  ForceSensorDynamics force_sensor_;
  Eigen::Vector2d sensed_position_m_{0.0, 0.0};
  Eigen::Vector2d sensed_velocity_m_per_s_{0.0, 0.0};
  Eigen::Vector2d sensed_force_N_{0.0, 0.0};
  Eigen::Vector2d desired_N_{0.0, 0.0};
  Eigen::Vector2d hand_force_N_{0.0, 0.0};
  AllocationOutput allocation_out_{};
  bool safe_ = false;
  bool bad_command_ = false;
  double time_s_ = 0.0;
  double last_period_s_ = 1e-3;
};

}  // namespace teleop::device::hybrid
