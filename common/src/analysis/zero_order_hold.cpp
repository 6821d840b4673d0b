#include "teleop/analysis/zero_order_hold.hpp"

#include <algorithm>
#include <cmath>

namespace teleop::analysis {
namespace {

/// exp(M) for a 3×3 matrix by scaling and squaring with a degree-18 Taylor series: after scaling ‖M‖∞ ≤ 1/2, so the
/// truncation error is below 2^-19/19! ≈ 1e-23 relative. Fixed-size: no allocation.
Eigen::Matrix3d Expm(const Eigen::Matrix3d& m) noexcept {
  const double norm = m.cwiseAbs().rowwise().sum().maxCoeff();
  int squarings = 0;
  if (norm > 0.5) squarings = static_cast<int>(std::ceil(std::log2(norm / 0.5)));
  if (squarings > 60) squarings = 60;
  const Eigen::Matrix3d scaled = m / std::ldexp(1.0, squarings);
  Eigen::Matrix3d result = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d term = Eigen::Matrix3d::Identity();
  for (int k = 1; k <= 18; ++k) {
    term = (term * scaled) / static_cast<double>(k);
    result += term;
  }
  for (int i = 0; i < squarings; ++i) result = (result * result).eval();
  return result;
}

}  // namespace

ZohBlock DiscretizeMassSpringDamper(double mass_kg, double damping_Ns_per_m, double stiffness_N_per_m,
                                    double step_s) noexcept {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  a(0, 1) = 1.0;
  a(1, 0) = -stiffness_N_per_m / mass_kg;
  a(1, 1) = -damping_Ns_per_m / mass_kg;
  a(1, 2) = 1.0 / mass_kg;
  const Eigen::Matrix3d e = Expm(a * step_s);
  ZohBlock block;
  block.phi = e.topLeftCorner<2, 2>();
  block.gamma = e.topRightCorner<2, 1>();
  return block;
}

ZohBlock DiscretizeMassSpringDamper(double mass_kg, double damping_Ns_per_m, double stiffness_N_per_m, double step_s,
                                    double input_delay_s) noexcept {
  ZohBlock block = DiscretizeMassSpringDamper(mass_kg, damping_Ns_per_m, stiffness_N_per_m, step_s);
  const double delay_s = std::clamp(input_delay_s, 0.0, step_s);
  if (delay_s >= step_s) {
    block.gamma_stale = block.gamma;
  } else if (delay_s > 0.0) {
    // Γ0 = ∫0^{h-τ} e^{As} ds·B is the ZOH input matrix over h - τ; Γ1 = Γ(h) - Γ0.
    const ZohBlock early = DiscretizeMassSpringDamper(mass_kg, damping_Ns_per_m, stiffness_N_per_m, step_s - delay_s);
    block.gamma_stale = block.gamma - early.gamma;
  }
  return block;
}

}  // namespace teleop::analysis
