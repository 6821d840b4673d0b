#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace teleop {

/// The most Cartesian degrees of freedom a device or a wire sample carries (x, y, z, roll, pitch, yaw).
inline constexpr int kMaxDof = 6;

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
