#pragma once

#include <Eigen/Core>

namespace teleop::device::hybrid {

/// The brakes' torque over one integration step, as a friction contact (implicit, Moreau-style). Given the joint
/// velocity v⁻ the step would end with without the brakes, the inverse joint inertia W = M⁻¹ and the brake
/// capacities c_i (joint side), the brake impulses λ (N·m·s) satisfy, per joint i,
///   |λ_i| ≤ c_i·h;   |λ_i| < c_i·h ⇒ v⁺_i = 0;   λ_i = −c_i·h ⇒ v⁺_i ≥ 0;   λ_i = +c_i·h ⇒ v⁺_i ≤ 0,
/// with v⁺ = v⁻ + W·λ. So each brake opposes its joint's motion (or, stuck, holds against whatever else acts) and
/// never exceeds its capacity. For a symmetric positive definite W this mixed LCP has one solution, found here by
/// trying the nine stick/slide modes. Then the kinetic energy change ½v⁺ᵀMv⁺ − ½v⁻ᵀMv⁻ = λᵀv⁺ − ½λᵀWλ ≤ 0: the
/// brakes never add energy.
struct BrakeImpulse {
  Eigen::Vector2d impulse_Nms{0.0, 0.0};
  Eigen::Vector2d velocity_rad_per_s{0.0, 0.0};  ///< v⁺.
  bool solved = false;  ///< False only for bad input (then λ = 0, v⁺ = v⁻: no brake, never added energy).
};

/// Real-time safe (fixed work, no allocation).
[[nodiscard]] BrakeImpulse SolveBrakeImpulse(const Eigen::Vector2d& free_velocity_rad_per_s,
                                             const Eigen::Matrix2d& inverse_inertia, const Eigen::Vector2d& capacity_Nm,
                                             double step_s) noexcept;

}  // namespace teleop::device::hybrid
