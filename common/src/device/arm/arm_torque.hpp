#pragma once

// The joint torques that render a tool force on an arm (docs/arms.md, "Write"):
//   τ = J_vᵀ·F                          the law's force at the tool point (translation only)
//     + G(q) [+ C(q, q̇)·q̇] [+ friction]  compensation (gravity always; Coriolis and friction from config)
//     + J_wᵀ·(−K_o·e_R − D_o·w)          orientation `hold`: a rotational spring to the orientation at activation
//     + N(q)ᵀ-projected posture          redundant arms: −K_p(q − q_p) − D_p·q̇, projected by N = I − J_tᵀ·J̄_tᵀ
//     + soft joint limits                a spring pushing back inside the last `margin` of each joint's range
// then clamped to each joint's effort limit. J_t is the task Jacobian (J_v, or [J_v; J_w] with orientation hold) and
// J̄_t = M⁻¹·J_tᵀ·Λ, Λ = (J_t·M⁻¹·J_tᵀ)⁻¹, its dynamically consistent inverse: J̄_tᵀ·N = 0, so the posture term
// changes neither the tool force nor the held orientation (Khatib 1987). N is applied as τ0 − J_tᵀ·Λ·J_t·M⁻¹·τ0
// (never formed), refined once. Cycle-safe: no allocation.

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "arm_model.hpp"
#include "joint_space.hpp"

namespace teleop::device::arm {

struct ArmTorqueConfig {
  bool hold_orientation = false;                  ///< Else `free`: no rotational term, J_t = J_v.
  double orientation_stiffness_Nm_per_rad = 0.0;  ///< K_o.
  double orientation_damping_Nms_per_rad = 0.0;   ///< D_o.
  double posture_stiffness_Nm_per_rad = 0.0;      ///< K_p (0: no posture term).
  double posture_damping_Nms_per_rad = 0.0;       ///< D_p.
  JointVector posture_q;                          ///< q_p (rad); empty: the middle of each bounded joint's range.
  double limit_margin = 0.1;                      ///< rad (m): the soft limit acts within this of a limit.
  double limit_stiffness_Nm_per_rad = 0.0;        ///< 0: no soft-limit term.
  bool coriolis_compensation = false;
  double friction_viscous_Nms_per_rad = 0.0;  ///< Compensated viscous friction per joint.
  double friction_coulomb_Nm = 0.0;           ///< Compensated Coulomb friction per joint (smoothed over 0.01 rad/s).
};

/// Every term of one Step, for telemetry and tests (N·m per joint; rendered force N in the base frame).
struct ArmTorqueTerms {
  JointVector task_Nm, gravity_Nm, coriolis_Nm, friction_Nm, orientation_Nm, posture_Nm, limit_Nm;
  JointVector commanded_Nm;  ///< The sum, before the clamp.
  JointVector applied_Nm;    ///< After the clamp to each joint's effort limit.
  int clamped_joints = 0;    ///< How many joints the clamp changed.
  /// The tool force the applied torques render: F + the task-space share of the clamp, J̄_vᵀ·(applied − commanded).
  Eigen::Vector3d rendered_force_N = Eigen::Vector3d::Zero();
  bool null_space_valid = false;  ///< Λ could be formed (else the posture term is off this cycle).
};

class ArmTorque {
 public:
  /// Sized for `model`'s arm; fills an empty posture_q with the middle of each joint's range (0 if unbounded).
  ArmTorque(const ArmModel& model, ArmTorqueConfig config);

  const ArmTorqueConfig& config() const noexcept { return config_; }
  /// The orientation `hold` keeps (base frame): set at activation.
  void HoldOrientation(const Eigen::Matrix3d& R_BT) noexcept { R_hold_ = R_BT; }

  /// The torques for tool force `f_B_N` (N, base frame) at the model's last Update (q, v as given to it). `coupling`
  /// false is the safe state: gravity compensation only (no force, no orientation, posture or limit term), clamped.
  const ArmTorqueTerms& Step(const ArmModel& model, const JointVector& q, const JointVector& v,
                             const Eigen::Vector3d& f_B_N, bool coupling) noexcept;
  const ArmTorqueTerms& terms() const noexcept { return terms_; }

  /// The dynamically consistent inverse of the last Step's task Jacobian, J̄_t (joints × 3 or 6).
  const JointTaskMatrix& J_bar() const noexcept { return J_bar_; }

 private:
  /// Step's coupled terms: the task's null space (J̄_t, N) and the posture torque projected into it.
  void NullSpacePosture(const ArmModel& model, const JointVector& q, const JointVector& v) noexcept;
  /// Step's coupled terms: the springs that push a bounded joint back from its limit margin.
  void JointLimits(const ArmModel& model, const JointVector& q) noexcept;

  ArmTorqueConfig config_;
  int n_ = 0;
  JointVector max_effort_;
  Eigen::Matrix3d R_hold_ = Eigen::Matrix3d::Identity();
  ArmTorqueTerms terms_;
  TaskJacobian J_t_;
  JointTaskMatrix Minv_Jt_, J_bar_;
  TaskMatrix Lambda_inv_;
  Eigen::LLT<TaskMatrix> Lambda_inv_llt_;
};

}  // namespace teleop::device::arm
