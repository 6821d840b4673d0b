#pragma once

#include <Eigen/Core>

#include "teleop/device/hybrid/motor_model.hpp"
#include "teleop/device/hybrid/particle_brake.hpp"

namespace teleop::device::hybrid {

/// Splits a desired handle force between the motors and the brakes (Kwon & Song §3, Fig. 5), joint by joint in
/// joint space (τ = Jᵀ·F, eq. 1):
/// - A joint's brake is engaged only when the desired joint torque opposes that joint's motion (measured by the
///   encoders), or, with the joint at rest (|q̇| < rest_velocity_rad_per_s), opposes the torque the operator applies
///   to it (measured by the handle force sensor, τ_h = Jᵀ·F_h). Otherwise the brake is released and the motor
///   renders everything (Fig. 5(b), release of the wall: the brake could only resist the outward motion).
/// - An engaged brake is commanded the magnitude it is asked for (never more than it can do); the motor supplies
///   the desired torque minus what the brake is estimated to deliver now (a copy of the brake's lag model, with
///   drag), so the fast motor covers the slow brake and hands over to it as it builds up.
/// - `dissipative_force_N` is a request for the brakes only (a friction or a hold force): it never reaches the
///   motors, and a joint's brake takes max(|its share of the desired torque|, |its share of this request|) when
///   both are dissipative there.
/// Consequences (tested): when a brake is engaged the motor torque has the sign of the desired torque and at most
/// its magnitude, so per joint the pair never injects more power than the motor alone rendering the desired force;
/// a brake is never commanded where it would have to do positive work.
struct AllocationConfig {
  MotorConfig motor{};
  BrakeConfig brake{};
  double rest_velocity_rad_per_s = 0.02;
  bool use_brakes = true;  ///< False: motors only (the active system the paper compares with).
  void Validate() const;
};

struct AllocationInput {
  Eigen::Matrix2d jacobian_m_per_rad = Eigen::Matrix2d::Identity();
  Eigen::Vector2d joint_velocity_rad_per_s{0.0, 0.0};
  Eigen::Vector2d hand_force_N{0.0, 0.0};         ///< Measured by the handle sensor, base frame.
  Eigen::Vector2d desired_force_N{0.0, 0.0};      ///< On the handle, motors and brakes, base frame.
  Eigen::Vector2d dissipative_force_N{0.0, 0.0};  ///< On the handle, brakes only, base frame.
  bool brakes_for_desired = true;  ///< False: desired_force_N goes to the motors only (brakes serve the request).
};

struct AllocationOutput {
  Eigen::Vector2d motor_joint_Nm{0.0, 0.0};           ///< Motor command, joint side.
  Eigen::Vector2d brake_shaft_Nm{0.0, 0.0};           ///< Brake command, shaft side, 0…max.
  Eigen::Vector2d brake_estimate_joint_Nm{0.0, 0.0};  ///< Signed torque the brakes are expected to exert now.
  Eigen::Vector2d desired_joint_Nm{0.0, 0.0};         ///< Jᵀ·desired_force_N.
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
