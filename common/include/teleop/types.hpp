#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace teleop {

/// The most degrees of freedom a device or a wire sample carries: 12 covers a 7-joint arm with a 6-DOF wrist
/// sensor's Cartesian axes, or a bimanual console of two 6-DOF devices driven as one pair (x, y, z, roll, pitch,
/// yaw per device). Storage of a DofVector is fixed at this size (12 doubles), whatever the configured dof.
inline constexpr int kMaxDof = 12;

/// A per-DOF vector with a run-time size of 1..kMaxDof and fixed storage: resizing it never touches the heap,
/// so it is safe inside the control cycle. The unit and frame are stated where a variable is declared.
using DofVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxDof, 1>;

/// Zero vector of `dof` entries.
inline DofVector ZeroDof(int dof) { return DofVector::Zero(dof); }

/// True when every entry is finite (no NaN, no infinity).
inline bool AllFinite(const DofVector& v) noexcept { return v.allFinite(); }

/// Which end of the link a process is.
enum class Role : std::uint8_t { kMaster = 0, kSlave = 1 };

inline const char* ToString(Role role) noexcept { return role == Role::kMaster ? "master" : "slave"; }

}  // namespace teleop
