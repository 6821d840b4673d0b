#include "device/hybrid/force_manipulability.hpp"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <numbers>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {

FmeAxes ForceManipulability(const Eigen::Matrix2d& jacobian_m_per_rad, double max_joint_torque_Nm) noexcept {
  FmeAxes axes;
  if (!jacobian_m_per_rad.allFinite() || !std::isfinite(max_joint_torque_Nm)) {
    return axes;
  }
  const Eigen::JacobiSVD<Eigen::Matrix2d> svd(jacobian_m_per_rad, Eigen::ComputeFullU);
  const double s_max = svd.singularValues()(0);
  const double s_min = svd.singularValues()(1);
  if (!(s_min > 0.0)) {
    return axes;
  }
  // F = U Σ⁻¹ Vᵀ τ: the image of the torque circle is an ellipse with semi-axes τ/σ_i along the columns of U.
  axes.min_force_N = max_joint_torque_Nm / s_max;
  axes.max_force_N = max_joint_torque_Nm / s_min;
  axes.min_direction = svd.matrixU().col(0);
  return axes;
}

std::vector<Eigen::Vector2d> FmeCurve(const Eigen::Matrix2d& jacobian_m_per_rad, double max_joint_torque_Nm,
                                      int points) {
  std::vector<Eigen::Vector2d> curve;
  if (points <= 0) {
    return curve;
  }
  const Eigen::Matrix2d jt_inverse = jacobian_m_per_rad.transpose().inverse();
  curve.reserve(static_cast<std::size_t>(points));
  for (int i = 0; i < points; ++i) {
    const double phi = 2.0 * std::numbers::pi * i / points;
    curve.emplace_back(jt_inverse * (max_joint_torque_Nm * Eigen::Vector2d{std::cos(phi), std::sin(phi)}));
  }
  return curve;
}

FmeMap MapForceManipulability(const FiveBar& kinematics, double motor_joint_torque_Nm, double brake_joint_torque_Nm,
                              double grid_step_m) {
  if (!(grid_step_m > 0.0) || !(motor_joint_torque_Nm > 0.0) || !(brake_joint_torque_Nm > 0.0)) {
    throw Error("hybrid FME map: grid step and torques must be > 0");
  }
  const FiveBarConfig& c = kinematics.config();
  FmeMap map;
  map.columns = static_cast<int>(std::floor((c.workspace_x_max_m - c.workspace_x_min_m) / grid_step_m + 1e-9)) + 1;
  map.rows = static_cast<int>(std::floor((c.workspace_y_max_m - c.workspace_y_min_m) / grid_step_m + 1e-9)) + 1;
  map.samples.reserve(static_cast<std::size_t>(map.columns) * static_cast<std::size_t>(map.rows));
  map.min_motor_force_N = std::numeric_limits<double>::infinity();
  map.min_brake_force_N = std::numeric_limits<double>::infinity();
  map.min_singularity_margin = std::numeric_limits<double>::infinity();
  for (int r = 0; r < map.rows; ++r) {
    for (int col = 0; col < map.columns; ++col) {
      FmeSample s;
      s.position_m = {c.workspace_x_min_m + col * grid_step_m, c.workspace_y_min_m + r * grid_step_m};
      Eigen::Vector2d q;
      Eigen::Matrix2d jac;
      s.in_workspace =
          kinematics.InWorkspace(s.position_m) && kinematics.Inverse(s.position_m, q) && kinematics.Jacobian(q, jac);
      if (s.in_workspace) {
        s.motor_min_force_N = ForceManipulability(jac, motor_joint_torque_Nm).min_force_N;
        s.brake_min_force_N = ForceManipulability(jac, brake_joint_torque_Nm).min_force_N;
        s.singularity_margin = kinematics.Margin(q).min;
        ++map.workspace_points;
        if (s.motor_min_force_N < map.min_motor_force_N) {
          map.min_motor_force_N = s.motor_min_force_N;
          map.min_motor_at_m = s.position_m;
        }
        if (s.brake_min_force_N < map.min_brake_force_N) {
          map.min_brake_force_N = s.brake_min_force_N;
          map.min_brake_at_m = s.position_m;
        }
        map.min_singularity_margin = std::min(map.min_singularity_margin, s.singularity_margin);
      }
      map.samples.push_back(s);
    }
  }
  if (map.workspace_points == 0) {
    throw Error("hybrid FME map: no grid point of the workspace rectangle is reachable within the joint limits");
  }
  return map;
}

}  // namespace teleop::device::hybrid
