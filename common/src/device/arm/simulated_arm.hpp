#pragma once

// The simulated arm (docs/arms.md, "The simulated arm"): the loopback plant of an arm, behind the joint-actuator
// seam, so the arm backend under test is the one that drives real joints.
//
// Dynamics of the same URDF: (M(q) + m_h·J_vᵀJ_v)·q̈ = τ − C(q, q̇)·q̇ − G(q) − τ_f(q̇) + τ_stop(q, q̇) + J_vᵀ·F_ext,
// integrated by semi-implicit (symplectic) Euler with `substeps` steps per period (q̇ first, then q with the new
// q̇), the written torques held over the period (zero-order hold). τ is each written torque clamped to the joint's
// effort limit; τ_f = b·q̇ + c·tanh(q̇ / 0.01 rad/s) (viscous and smoothed Coulomb friction); τ_stop a stiff
// spring-damper beyond each joint's limit (one-sided). F_ext at the tool point: the operator's hand on a master
// (a mass m_h, a spring k_h and damper b_h to the tool's position at start, plus a scripted push), or the
// environment on a slave (a plane the tool is pushed out of: a spring-damper that only pushes). Reported positions
// are rounded to the encoder's resolution.

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "arm_model.hpp"
#include "joint_actuator.hpp"
#include "joint_space.hpp"

namespace teleop::device::arm {

struct SimulatedArmConfig {
  JointVector initial_q;  ///< rad; empty: the middle of each bounded joint's range.
  double viscous_Nms_per_rad = 0.0;
  double coulomb_Nm = 0.0;
  double encoder_resolution_rad = 0.0;  ///< 0: exact.
  int substeps = 4;
  double stop_stiffness_Nm_per_rad = 2000.0;
  double stop_damping_Nms_per_rad = 20.0;
  /// The operator's hand at the tool (master): active when hand_mass_kg > 0 or hand_stiffness_N_per_m > 0.
  double hand_mass_kg = 0.0;
  double hand_damping_Ns_per_m = 0.0;
  double hand_stiffness_N_per_m = 0.0;
  Eigen::Vector3d hand_push_N = Eigen::Vector3d::Zero();  ///< The scripted push (base frame), from push_start_s on.
  double hand_push_start_s = 0.0;
  /// The environment at the tool (slave): the points p with normal·p > offset_m are inside the obstacle.
  bool environment = false;
  Eigen::Vector3d environment_normal = Eigen::Vector3d::UnitZ();  ///< Unit, pointing into the obstacle.
  double environment_offset_m = 0.0;
  double environment_stiffness_N_per_m = 0.0;
  double environment_damping_Ns_per_m = 0.0;
};

class SimulatedArm final : public JointBus {
 public:
  /// Its own model of the arm (the same chain as the backend's). Throws teleop::Error on a bad config.
  SimulatedArm(ArmChain arm, const Eigen::Vector3d& gravity_B, SimulatedArmConfig config);
  ~SimulatedArm() override;

  int joint_count() const noexcept override { return n_; }
  JointActuator& joint(int i) noexcept override;
  void Exchange(double period_s) noexcept override;

  // Test access: the true state and the forces at the tool.
  const JointVector& q() const noexcept { return q_; }
  const JointVector& v() const noexcept { return v_; }
  const Eigen::Vector3d& p_BT() const noexcept { return model_.p_BT(); }
  /// The environment's force on the tool (N, base frame) at the last substep; zero in free space.
  const Eigen::Vector3d& environment_force_N() const noexcept { return env_force_N_; }
  /// The tool's penetration of the environment plane at the last substep (m; ≤ 0 outside).
  double penetration_m() const noexcept { return penetration_m_; }
  double time_s() const noexcept { return time_s_; }
  /// Makes joint `i` report a fault (tests of the backend's reaction).
  void InjectFault(int i, std::uint32_t code) noexcept;
  /// Makes joint `i` report a non-finite position (tests).
  void InjectNonFinite(int i) noexcept;

 private:
  class Joint;
  void Substep(double h) noexcept;

  ArmModel model_;
  SimulatedArmConfig config_;
  int n_ = 0;
  std::vector<std::unique_ptr<Joint>> joints_;
  JointVector q_, v_, tau_, max_effort_;
  JointVector lower_, upper_;
  Eigen::Vector3d hand_rest_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d env_force_N_ = Eigen::Vector3d::Zero();
  double penetration_m_ = 0.0;
  double time_s_ = 0.0;
  JointMatrix M_eff_;
  Eigen::LLT<JointMatrix> llt_;
};

}  // namespace teleop::device::arm
