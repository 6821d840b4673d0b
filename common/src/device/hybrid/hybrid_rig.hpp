#pragma once

#include <Eigen/Core>
#include <array>

#include "device/hybrid/five_bar.hpp"
#include "device/hybrid/handle_force_sensor.hpp"
#include "device/hybrid/motor_model.hpp"
#include "device/hybrid/particle_brake.hpp"
#include "device/hybrid/rig_sensing.hpp"

namespace teleop::device::hybrid {

/// The simulated hybrid haptic device: the five-bar with a motor and a particle brake on each active joint, the
/// handle force sensor, and rigid-body dynamics M(q)·q̈ + C(q, q̇)·q̇ + b·q̇ = τ_motor + τ_brake + J(q)ᵀ·F_hand, with
/// M(q) = diag(joint inertia) + m·JᵀJ (actuator rotors and pulleys reflected to the joints, plus a point mass m at
/// the handle: links, handle and whatever the operator's hand adds). Integrated by semi-implicit Euler over
/// `substeps` sub-steps per Step, the brakes as an implicit friction contact (SolveBrakeImpulse), so a brake never
/// adds energy. Inertia defaults are estimates for the paper's rig (it gives none): 0.02 kg·m² per joint, 0.3 kg.
struct HybridRigConfig {
  FiveBarConfig geometry{};
  MotorConfig motor{};
  BrakeConfig brake{};
  HandleForceSensorConfig force_sensor{};
  ForceSensorDynamicsConfig force_sensor_dynamics{};  ///< Noise and bandwidth (the scenarios' and device's reading).
  EncoderConfig encoders{};                           ///< Quantization and velocity estimate (the controller's view).
  double joint_inertia_kgm2 = 0.02;
  double handle_mass_kg = 0.3;
  double joint_damping_Nms_per_rad = 0.01;  ///< Viscous friction of bearings and tendons, per joint.
  /// Coulomb friction of bearings and tendons per joint (N·m, joint side; an estimate, 0.1 N·m ≈ 0.5 N at the
  /// handle: §5 "the computed forces were a little different from the measured ones because of the friction of the
  /// mechanism"). Acts like an always-on brake in the friction solver, with the brake's static_ratio.
  double joint_coulomb_Nm = 0.1;
  int substeps = 10;  ///< Integration sub-steps per Step (1..1000).
  Eigen::Vector2d initial_position_m{0.0, 0.200};

  void Validate() const;  ///< teleop::Error naming the bad field (also the initial position out of the workspace).
};

/// What the rig did over the last Step, all base frame unless said otherwise.
struct RigState {
  Eigen::Vector2d joint_rad{0.0, 0.0};
  Eigen::Vector2d joint_velocity_rad_per_s{0.0, 0.0};
  Eigen::Vector2d position_m{0.0, 0.0};
  Eigen::Vector2d velocity_m_per_s{0.0, 0.0};
  Eigen::Vector2d measured_hand_force_N{0.0, 0.0};  ///< Handle force sensor.
  Eigen::Vector2d motor_joint_Nm{0.0, 0.0};         ///< Delivered (after lag and saturation), joint side.
  Eigen::Vector2d brake_joint_Nm{0.0, 0.0};         ///< Exerted by the brakes, joint side, step average.
  Eigen::Vector2d friction_joint_Nm{0.0, 0.0};      ///< Exerted by the joints' Coulomb friction, step average.
  Eigen::Vector2d brake_capacity_joint_Nm{0.0, 0.0};
  Eigen::Vector2d rendered_force_N{0.0, 0.0};  ///< (Jᵀ)⁻¹(τ_motor + τ_brake): the actuators' force on the handle.
  double brake_energy_J = 0.0;                 ///< Cumulative work of the brakes on the linkage (≤ 0).
  double friction_energy_J = 0.0;              ///< Cumulative work of the joints' Coulomb friction (≤ 0).
  double motor_energy_J = 0.0;                 ///< Cumulative work of the motors on the linkage.
  bool singular = false;                       ///< The linkage reached a configuration with no Jacobian.
};

class HybridRig {
 public:
  explicit HybridRig(const HybridRigConfig& config);  ///< Validates (teleop::Error).

  /// Holds the commands over period_s: motor joint torques (N·m, joint side, saturated by the motor model), brake
  /// shaft commands (N·m, 0…max), hand force on the handle (N, base frame). Real-time safe.
  void Step(const Eigen::Vector2d& motor_command_joint_Nm, const Eigen::Vector2d& brake_command_shaft_Nm,
            const Eigen::Vector2d& hand_force_N, double period_s) noexcept;

  const RigState& state() const noexcept { return state_; }
  const FiveBar& kinematics() const noexcept { return kinematics_; }
  const HybridRigConfig& config() const noexcept { return config_; }
  /// Kinetic energy ½q̇ᵀM(q)q̇ (J).
  [[nodiscard]] double KineticEnergyJ() const noexcept;
  /// Puts the handle at rest at p (must be in the workspace; false otherwise) and resets the actuators.
  [[nodiscard]] bool Reset(const Eigen::Vector2d& position_m) noexcept;

 private:
  [[nodiscard]] bool Inertia(const Eigen::Vector2d& q, Eigen::Matrix2d& jac, Eigen::Matrix2d& inertia) const noexcept;
  void UpdateCartesian() noexcept;

  HybridRigConfig config_;
  FiveBar kinematics_;
  std::array<MotorModel, 2> motors_;
  std::array<ParticleBrake, 2> brakes_;
  RigState state_;
  bool stuck_[2] = {true, true};  ///< The joint was held at rest by friction in the last sub-step.
};

}  // namespace teleop::device::hybrid
