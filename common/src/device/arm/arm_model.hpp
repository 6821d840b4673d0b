#pragma once

// An arm's kinematics and dynamics at one configuration, from its KDL chain (docs/arms.md). Every KDL solver and
// array is sized when the model is built; Update and every query after it run without heap allocation (checked by
// tests/device/arm with the allocation counter), so the model runs inside the control cycle.
//
// Names (Drake's monogram notation): B the base link's frame, T the tool point (tool link frame moved by the tool
// offset). p_BT the tool point's position in B (m); R_BT its orientation; J_BT the 6 × n geometric Jacobian in B
// (rows v_BT then w_BT); M_q the joint-space inertia (kg·m², kg for prismatic joints); C_qv the Coriolis and
// centrifugal torques C(q, q̇)·q̇ (N·m); G_q the torques that hold the arm against gravity (N·m).

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <kdl/chaindynparam.hpp>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <kdl/jacobian.hpp>
#include <kdl/jntarray.hpp>
#include <kdl/jntspaceinertiamatrix.hpp>
#include <memory>

#include "arm_chain.hpp"
#include "joint_space.hpp"

namespace teleop::device::arm {

class ArmModel {
 public:
  /// Sizes every solver for `arm`. `gravity_B` is the vector gravity points along, in the base frame (m/s²), e.g.
  /// (0, 0, -9.81) for a base whose z axis points up.
  ArmModel(ArmChain arm, const Eigen::Vector3d& gravity_B);
  ArmModel(const ArmModel&) = delete;
  ArmModel& operator=(const ArmModel&) = delete;

  const ArmChain& arm() const noexcept { return arm_; }
  int joint_count() const noexcept { return n_; }

  /// Evaluates FK, J_BT, M_q, C_qv and G_q at q (rad or m) and q̇ (rad/s or m/s). False when a KDL solver reports an
  /// error or a size does not match the chain (nothing else changes then). No allocation.
  [[nodiscard]] bool Update(const JointVector& q, const JointVector& v) noexcept;

  const Eigen::Vector3d& p_BT() const noexcept { return p_BT_; }  ///< m, base frame.
  const Eigen::Matrix3d& R_BT() const noexcept { return R_BT_; }
  const ToolJacobian& J_BT() const noexcept { return J_BT_; }
  const JointMatrix& M_q() const noexcept { return M_q_; }
  const JointVector& C_qv() const noexcept { return C_qv_; }  ///< N·m.
  const JointVector& G_q() const noexcept { return G_q_; }    ///< N·m.
  /// The tool point's linear velocity J_v·q̇ at the last Update (m/s, base frame).
  const Eigen::Vector3d& v_BT() const noexcept { return v_BT_; }

  /// Translational manipulability √det(J_v J_vᵀ) at the last Update (m³ for revolute joints; 0 at a singularity).
  double TranslationalManipulability() const noexcept;
  /// The arm's apparent mass at the tool along the unit direction `n_B` (kg): 1 / (nᵀ J_v M⁻¹ J_vᵀ n). +inf when the
  /// arm cannot move along n (nᵀ J_v M⁻¹ J_vᵀ n = 0). No allocation.
  double ApparentMass(const Eigen::Vector3d& n_B) const noexcept;
  /// M_q⁻¹ · x at the last Update (Cholesky of M_q, computed by Update). No allocation.
  JointVector SolveInertia(const JointVector& x) const noexcept;

 private:
  ArmChain arm_;
  int n_ = 0;
  KDL::ChainFkSolverPos_recursive fk_;
  KDL::ChainJntToJacSolver jac_;
  KDL::ChainDynParam dyn_;
  KDL::JntArray q_kdl_, v_kdl_, c_kdl_, g_kdl_;
  KDL::Jacobian j_kdl_;
  KDL::JntSpaceInertiaMatrix m_kdl_;
  KDL::Frame x_kdl_;

  Eigen::Vector3d p_BT_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_BT_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d v_BT_ = Eigen::Vector3d::Zero();
  ToolJacobian J_BT_;
  JointMatrix M_q_;
  JointVector C_qv_, G_q_;
  Eigen::LLT<JointMatrix> M_llt_;
};

}  // namespace teleop::device::arm
