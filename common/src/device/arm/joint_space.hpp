#pragma once

// Joint space and task space as separate types (docs/arms.md, "Frames and names"): a joint torque is never passed as
// a tool force. Every vector and matrix has fixed storage (kMaxJoints), so resizing one at configure time and using
// it in the cycle never touches the heap.

#include <Eigen/Core>

namespace teleop::device::arm {

/// The most joints an arm of this backend has: a 7-joint arm on a linear rail.
inline constexpr int kMaxJoints = 8;

using JointVectorBase = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxJoints, 1>;

/// One entry per joint, in the chain's joint order (base to tool). The unit is stated where a variable is declared
/// (rad, rad/s, N·m). Built from another Eigen expression only explicitly, so a task-space vector (Eigen::Vector3d)
/// never converts silently into a joint vector.
class JointVector : public JointVectorBase {
 public:
  JointVector() = default;
  explicit JointVector(Eigen::Index joints) : JointVectorBase(JointVectorBase::Zero(joints)) {}
  template <typename Other>
  explicit JointVector(const Eigen::MatrixBase<Other>& other) : JointVectorBase(other) {}
  template <typename Other>
  JointVector& operator=(const Eigen::MatrixBase<Other>& other) {
    JointVectorBase::operator=(other);
    return *this;
  }
};

/// Joint-space square matrix (the inertia M(q), a null-space projector), joints × joints.
using JointMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxJoints, kMaxJoints>;

/// The tool's geometric Jacobian in the base frame, 6 × joints: rows 0..2 map q̇ to the tool point's linear
/// velocity v_BT (m/s), rows 3..5 to its angular velocity w_BT (rad/s) (KDL's twist order).
using ToolJacobian = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxJoints>;

/// A task-space Jacobian of 3 (translation) or 6 (translation and rotation) rows, joints columns.
using TaskJacobian = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxJoints>;
/// A task-space square matrix (3 × 3 or 6 × 6): the operational-space inertia Λ.
using TaskMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 6, 6>;
/// A task-space vector of 3 or 6 entries (force then moment, N and N·m; or velocity then angular velocity).
using TaskVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, 6, 1>;
/// A joints × task matrix (the dynamically consistent inverse J̄ = M⁻¹ Jᵀ Λ).
using JointTaskMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxJoints, 6>;

}  // namespace teleop::device::arm
