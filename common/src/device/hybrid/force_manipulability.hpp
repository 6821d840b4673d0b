#pragma once

#include <Eigen/Core>
#include <vector>

#include "device/hybrid/five_bar.hpp"

namespace teleop::device::hybrid {

/// The force manipulability ellipsoid (FME) of Kwon & Song eqs. 1–2: τ = Jᵀ·F, F = (Jᵀ)⁻¹·τ, with the joint torque
/// vector on the circle ‖τ‖ = max_joint_torque_Nm. Its smallest semi-axis is the force the actuators can produce in
/// every direction: F_min = τ_max / σ_max(J); its largest is τ_max / σ_min(J).
struct FmeAxes {
  double min_force_N = 0.0;
  double max_force_N = 0.0;
  Eigen::Vector2d min_direction{1.0, 0.0};  ///< Unit direction of the smallest semi-axis, base frame.
};

/// FME semi-axes at a Jacobian J (m/rad) for a joint torque bound τ_max (N·m at the joint). Zero forces when J is
/// singular or not finite.
[[nodiscard]] FmeAxes ForceManipulability(const Eigen::Matrix2d& jacobian_m_per_rad,
                                          double max_joint_torque_Nm) noexcept;

/// The FME curve itself: F(φ) = (Jᵀ)⁻¹·τ_max·[cos φ, sin φ]ᵀ for `points` angles φ in [0, 2π), N.
[[nodiscard]] std::vector<Eigen::Vector2d> FmeCurve(const Eigen::Matrix2d& jacobian_m_per_rad,
                                                    double max_joint_torque_Nm, int points);

/// One grid point of the workspace map.
struct FmeSample {
  Eigen::Vector2d position_m{0.0, 0.0};  ///< Handle position, base frame.
  bool in_workspace = false;
  double motor_min_force_N = 0.0;
  double brake_min_force_N = 0.0;
  double singularity_margin = 0.0;  ///< SingularityMargin::min.
};

/// The FME over the workspace: a grid of step `grid_step_m` over the design rectangle; only reachable points count.
struct FmeMap {
  std::vector<FmeSample> samples;
  int columns = 0;
  int rows = 0;
  double min_motor_force_N = 0.0;
  double min_brake_force_N = 0.0;
  Eigen::Vector2d min_motor_at_m{0.0, 0.0};
  Eigen::Vector2d min_brake_at_m{0.0, 0.0};
  double min_singularity_margin = 0.0;
  int workspace_points = 0;
};

/// Builds the map (set-up/analysis code, allocates). Motor and brake torques are the joint-side bounds (actuator
/// shaft torque × pulley ratio). Throws teleop::Error for a non-positive step or torque.
[[nodiscard]] FmeMap MapForceManipulability(const FiveBar& kinematics, double motor_joint_torque_Nm,
                                            double brake_joint_torque_Nm, double grid_step_m);

}  // namespace teleop::device::hybrid
