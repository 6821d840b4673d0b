// KDL behind the ArmModel (arm_model.hpp): every array sized in the constructor, nothing allocated by Update.

#include "arm_model.hpp"

#include <Eigen/LU>
#include <cmath>
#include <limits>
#include <utility>

namespace teleop::device::arm {

ArmModel::ArmModel(ArmChain arm, const Eigen::Vector3d& gravity_B)
    : arm_(std::move(arm)),
      n_(arm_.joint_count()),
      fk_(arm_.chain),
      jac_(arm_.chain),
      dyn_(arm_.chain, KDL::Vector(gravity_B.x(), gravity_B.y(), gravity_B.z())),
      q_kdl_(static_cast<unsigned>(n_)),
      v_kdl_(static_cast<unsigned>(n_)),
      c_kdl_(static_cast<unsigned>(n_)),
      g_kdl_(static_cast<unsigned>(n_)),
      j_kdl_(static_cast<unsigned>(n_)),
      m_kdl_(static_cast<unsigned>(n_)),
      J_BT_(ToolJacobian::Zero(6, n_)),
      M_q_(JointMatrix::Identity(n_, n_)),
      C_qv_(n_),
      G_q_(n_),
      M_llt_(n_) {
  M_llt_.compute(M_q_);
}

bool ArmModel::Update(const JointVector& q, const JointVector& v) noexcept {
  if (q.size() != n_ || v.size() != n_) return false;
  for (int i = 0; i < n_; ++i) {
    q_kdl_(static_cast<unsigned>(i)) = q[i];
    v_kdl_(static_cast<unsigned>(i)) = v[i];
  }
  if (fk_.JntToCart(q_kdl_, x_kdl_) < 0) return false;
  if (jac_.JntToJac(q_kdl_, j_kdl_) < 0) return false;
  if (dyn_.JntToMass(q_kdl_, m_kdl_) < 0) return false;
  if (dyn_.JntToCoriolis(q_kdl_, v_kdl_, c_kdl_) < 0) return false;
  if (dyn_.JntToGravity(q_kdl_, g_kdl_) < 0) return false;
  for (int r = 0; r < 3; ++r) {
    p_BT_[r] = x_kdl_.p[r];
    for (int c = 0; c < 3; ++c) R_BT_(r, c) = x_kdl_.M(r, c);
  }
  J_BT_ = j_kdl_.data;
  M_q_ = m_kdl_.data;
  C_qv_ = c_kdl_.data;
  G_q_ = g_kdl_.data;
  v_BT_ = J_BT_.topRows<3>() * v;
  M_llt_.compute(M_q_);
  return M_llt_.info() == Eigen::Success;
}

double ArmModel::TranslationalManipulability() const noexcept {
  const Eigen::Matrix3d JJt = J_BT_.topRows<3>() * J_BT_.topRows<3>().transpose();
  return std::sqrt(std::max(0.0, JJt.determinant()));
}

double ArmModel::ApparentMass(const Eigen::Vector3d& n_B) const noexcept {
  const JointVector Jt_n(J_BT_.topRows<3>().transpose() * n_B);
  const double mobility = Jt_n.dot(SolveInertia(Jt_n));
  if (!(mobility > 0.0)) return std::numeric_limits<double>::infinity();
  return 1.0 / mobility;
}

JointVector ArmModel::SolveInertia(const JointVector& x) const noexcept { return JointVector(M_llt_.solve(x)); }

}  // namespace teleop::device::arm
