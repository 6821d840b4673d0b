#pragma once

#include <Eigen/Core>

namespace teleop::analysis {

/// Exact zero-order-hold discretization of m·ẍ + b·ẋ + k·x = u over one step h (Abbott & Okamura eq. 27):
/// [x; v](k+1) = phi·[x; v](k) + gamma·u(k), u held over the step.
///
/// With an input delayed by τ (0 ≤ τ ≤ h: u(k) computed at kh acts from kh + τ, u(k-1) before that) the same
/// step splits at the delay: [x; v](k+1) = phi·[x; v](k) + (gamma - gamma_stale)·u(k) + gamma_stale·u(k-1), with
/// Γ0 = gamma - gamma_stale = ∫0^{h-τ} e^{As} ds·B and Γ1 = gamma_stale = ∫_{h-τ}^{h} e^{As} ds·B. gamma_stale is 0
/// without delay and equals gamma for τ = h.
struct ZohBlock {
  Eigen::Matrix2d phi = Eigen::Matrix2d::Identity();
  Eigen::Vector2d gamma = Eigen::Vector2d::Zero();
  Eigen::Vector2d gamma_stale = Eigen::Vector2d::Zero();  ///< Γ1: the part of gamma the previous input still drives.
};

/// The one ZOH discretization of the project, used by the stability analysis (discrete_model.hpp) and by the
/// loopback plant, so that the plant the processes run is the plant the analysis predicts. By the exponential of
/// the augmented 3×3 system d/dt [x, v, u] = [[0, 1, 0], [-k/m, -b/m, 1/m], [0, 0, 0]]·[x, v, u] (Franklin et al.
/// §4.3): its top-left block is phi, its top-right column gamma. Fixed-size, allocation-free and exception-free, so
/// the plant may call it inside the cycle. Requires mass > 0 and step > 0.
ZohBlock DiscretizeMassSpringDamper(double mass_kg, double damping_Ns_per_m, double stiffness_N_per_m,
                                    double step_s) noexcept;
/// The same with the input delayed by `input_delay_s` (clamped to 0..step_s), which fills gamma_stale.
ZohBlock DiscretizeMassSpringDamper(double mass_kg, double damping_Ns_per_m, double stiffness_N_per_m, double step_s,
                                    double input_delay_s) noexcept;

}  // namespace teleop::analysis
