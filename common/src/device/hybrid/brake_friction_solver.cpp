#include "device/hybrid/brake_friction_solver.hpp"

#include <Eigen/LU>
#include <array>
#include <cmath>

namespace teleop::device::hybrid {
namespace {

enum class Mode : int { kStick = 0, kSlidePositive = 1, kSlideNegative = 2 };  // slide±: joint moving ±, λ = ∓c·h

constexpr double kTolerance = 1e-12;

using Modes = std::array<Mode, 2>;

/// The impulse of one mode combination: a sliding joint's at its bound against its motion; the sticking joints'
/// from W_SS λ_S = −(v0 + W λ_F)_S.
Eigen::Vector2d ImpulseOf(const Modes& mode, const Eigen::Vector2d& v0, const Eigen::Matrix2d& w,
                          const Eigen::Vector2d& bound) noexcept {
  Eigen::Vector2d lambda = Eigen::Vector2d::Zero();
  for (int i = 0; i < 2; ++i) {
    if (mode[i] == Mode::kSlidePositive) {
      lambda(i) = -bound(i);
    } else if (mode[i] == Mode::kSlideNegative) {
      lambda(i) = bound(i);
    }
  }
  const bool stick0 = mode[0] == Mode::kStick;
  const bool stick1 = mode[1] == Mode::kStick;
  if (stick0 && stick1) {
    lambda = -w.inverse() * v0;
  } else if (stick0) {
    lambda(0) = -(v0(0) + w(0, 1) * lambda(1)) / w(0, 0);
  } else if (stick1) {
    lambda(1) = -(v0(1) + w(1, 0) * lambda(0)) / w(1, 1);
  }
  return lambda;
}

/// Whether the combination is consistent: a sticking joint's impulse within its bound, a sliding joint moving the
/// way its mode says (velocity tolerance `tol_v`).
bool Consistent(const Modes& mode, const Eigen::Vector2d& lambda, const Eigen::Vector2d& v,
                const Eigen::Vector2d& bound, double tol_v) noexcept {
  for (int i = 0; i < 2; ++i) {
    bool ok = true;
    switch (mode[i]) {
      case Mode::kStick:
        ok = std::abs(lambda(i)) <= bound(i) * (1.0 + 1e-12) + 1e-300;
        break;
      case Mode::kSlidePositive:
        ok = v(i) >= -tol_v;
        break;
      case Mode::kSlideNegative:
        ok = v(i) <= tol_v;
        break;
    }
    if (!ok) return false;
  }
  return true;
}

}  // namespace

BrakeImpulse SolveBrakeImpulse(const Eigen::Vector2d& free_velocity_rad_per_s, const Eigen::Matrix2d& inverse_inertia,
                               const Eigen::Vector2d& capacity_Nm, double step_s) noexcept {
  BrakeImpulse out;
  out.velocity_rad_per_s = free_velocity_rad_per_s;
  if (!free_velocity_rad_per_s.allFinite() || !inverse_inertia.allFinite() || !capacity_Nm.allFinite() ||
      !std::isfinite(step_s) || step_s <= 0.0 || capacity_Nm.minCoeff() < 0.0 || inverse_inertia(0, 0) <= 0.0 ||
      inverse_inertia.determinant() <= 0.0) {
    return out;
  }
  const Eigen::Vector2d bound = capacity_Nm * step_s;
  const Eigen::Vector2d& v0 = free_velocity_rad_per_s;
  const Eigen::Matrix2d& w = inverse_inertia;
  const double scale = 1.0 + v0.cwiseAbs().maxCoeff();
  for (int m = 0; m < 9; ++m) {
    const Modes mode{static_cast<Mode>(m % 3), static_cast<Mode>(m / 3)};
    const Eigen::Vector2d lambda = ImpulseOf(mode, v0, w, bound);
    const Eigen::Vector2d v = v0 + w * lambda;
    if (!Consistent(mode, lambda, v, bound, kTolerance * scale)) continue;
    out.impulse_Nms = lambda;
    out.velocity_rad_per_s = v;
    // A stuck joint ends exactly at rest (removes round-off that could otherwise creep).
    for (int i = 0; i < 2; ++i) {
      if (mode[i] == Mode::kStick) {
        out.velocity_rad_per_s(i) = 0.0;
      }
    }
    out.solved = true;
    return out;
  }
  return out;
}

}  // namespace teleop::device::hybrid
