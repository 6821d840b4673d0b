#pragma once

#include <Eigen/Core>

#include "device/hybrid/motor_model.hpp"
#include "device/hybrid/particle_brake.hpp"

namespace teleop::device::hybrid {

/// Splits what an environment asks of the device between the motors and the brakes (Kwon & Song §3, Fig. 5; §4,
/// Fig. 6(a)), joint by joint in joint space (τ = Jᵀ·F, eq. 1). Three requests, each naming who renders it:
/// - `motor_force_N`: the motors alone (the hybrid wall's damper, Fig. 6(a): "the brakes are activated and the motors
///   generate the damping force as a function of the end-effector velocity"). Motor torque asked: τ_m = Jᵀ·F_m.
/// - `desired_force_N`: shared (the law's command): where it is dissipative the brake takes what it can and the motor
///   the rest; elsewhere the motor renders it. Motor torque asked: τ_d − (the brake's estimated share of τ_d).
/// - `dissipative_force_N`: the brakes alone (the hybrid wall's hold, a friction). Brake torque asked: |τ_r|, never
///   passed to the motors.
/// The forces add: the motor delivers τ_m + τ_d − share, the brake its own torque, in parallel on the joint, so with
/// the brake at its estimate the joint gets τ_m + τ_d + τ_r (tested: total = motor + brake within the estimate).
///
/// When a brake may act (§3: "motors and brakes can be used simultaneously when the force is desired in the
/// direction opposite to the motion; otherwise, only motors can be used"), with τ_total = τ_m + τ_d + τ_r:
/// - moving (|q̇| ≥ rest_velocity_rad_per_s, encoders): τ_total opposes q̇;
/// - at rest: τ_total opposes the operator's torque τ_h = Jᵀ·F_h (force sensor), unless the active request
///   τ_a = τ_m + τ_d opposes τ_h and is larger than it: then the reaction is larger than what the hand exerts and the
///   handle is released outward (Fig. 5(b)), which a brake can only resist, so the brake is released and the motors
///   alone render the force (a brake left on would stall the handle in the wall).
/// A brake that may act is asked for the dissipative components that oppose the reference direction (q̇, or τ_h at
/// rest), at most |τ_total|; otherwise it is released (command 0; its residual drag remains).
/// Consequences (tested): a brake is never engaged while the desired force assists the motion; the motor never gives
/// more than τ_m + τ_d in the direction of motion, so the pair never injects more power than the motors alone.
struct AllocationConfig {
  MotorConfig motor{};
  BrakeConfig brake{};
  double rest_velocity_rad_per_s = 0.02;
  bool use_brakes = true;  ///< False: motors only (the active system the paper compares with).
  /// The simulated rig's allocation uses AllocationBrakeModel(rig brake, this); the real rig uses the brake keys as
  /// given (they are the model). 0..0.9.
  double brake_model_mismatch = 0.2;
  void Validate() const;
};

/// The brake model an allocation computes with when the brake it drives is simulated: not the simulated brake (a
/// controller never has the exact plant). With mismatch m (default 0.2) it believes the brake m faster (lag × (1 − m))
/// and m/2 stronger (torque × (1 + m/2)) than it is and knows neither its remanence nor its static torque; m = 0
/// gives the simulated brake's own lag and torque.
[[nodiscard]] BrakeConfig AllocationBrakeModel(const BrakeConfig& brake, double mismatch = 0.2);

struct AllocationInput {
  Eigen::Matrix2d jacobian_m_per_rad = Eigen::Matrix2d::Identity();
  Eigen::Vector2d joint_velocity_rad_per_s{0.0, 0.0};
  Eigen::Vector2d hand_force_N{0.0, 0.0};         ///< Measured by the handle sensor, base frame.
  Eigen::Vector2d motor_force_N{0.0, 0.0};        ///< On the handle, motors only, base frame.
  Eigen::Vector2d desired_force_N{0.0, 0.0};      ///< On the handle, motors and brakes, base frame.
  Eigen::Vector2d dissipative_force_N{0.0, 0.0};  ///< On the handle, brakes only, base frame.
  bool brakes_for_desired = true;  ///< False: desired_force_N goes to the motors only (brakes serve the request).
};

struct AllocationOutput {
  Eigen::Vector2d motor_joint_Nm{0.0, 0.0};           ///< Motor command, joint side.
  Eigen::Vector2d brake_shaft_Nm{0.0, 0.0};           ///< Brake command, shaft side, 0…max.
  Eigen::Vector2d brake_estimate_joint_Nm{0.0, 0.0};  ///< Signed torque the brakes are expected to exert now.
  Eigen::Vector2d desired_joint_Nm{0.0, 0.0};         ///< τ_total = Jᵀ·(motor + desired + dissipative force).
  Eigen::Vector2d brake_ask_joint_Nm{0.0, 0.0};       ///< What the brake is asked for, joint side (≥ 0).
  bool brake_engaged[2] = {false, false};
};

/// Config + state (the brake lag estimate) + Step. Real-time safe; non-finite inputs give zero motor torque and
/// released brakes.
class MotorBrakeAllocator {
 public:
  explicit MotorBrakeAllocator(const AllocationConfig& config);
  [[nodiscard]] AllocationOutput Step(const AllocationInput& in, double period_s) noexcept;
  void Reset() noexcept;
  const AllocationConfig& config() const noexcept { return config_; }

 private:
  AllocationConfig config_;
  ParticleBrake brake_model_[2];
};

}  // namespace teleop::device::hybrid
