#pragma once

#include <complex>

#include "teleop/analysis/discrete_model.hpp"

namespace teleop::analysis {

/// Damping ratio of one z-plane eigenvalue: s = ln(z)/T (eq. 30, principal branch), ζ = sin(atan(-Re s / |Im s|))
/// (eq. 31). ζ < 0 exactly when |z| > 1. A real eigenvalue gives ±1; z = 0 (a pure delay) gives 1.
double DampingRatio(std::complex<double> z, double period_s) noexcept;

/// What the eigenvalues of one model say.
struct ModalSummary {
  double spectral_radius = 0.0;       ///< max |z|; > 1 means an unstable equilibrium.
  double min_damping_ratio = 1.0;     ///< min ζ over the eigenvalues (Fig. 5's "minimum damping ratio").
  std::complex<double> dominant_z{};  ///< The eigenvalue of least damping ratio.
};

/// Eigenvalues of A (Eigen's real Schur form, no eigenvectors) mapped to the s-plane. Allocation-free.
ModalSummary AnalyzeEigenvalues(const StateMatrix& a, double period_s) noexcept;

/// The same for the delay-line model (AssembleDelayedStateMatrix); allocates.
ModalSummary AnalyzeEigenvalues(const Eigen::MatrixXd& a, double period_s);

/// Spectral radius only: the cheapest stability test (|z| ≤ 1), used by the bisection.
double SpectralRadius(const StateMatrix& a) noexcept;
/// The same for the delay-line model; allocates.
double SpectralRadius(const Eigen::MatrixXd& a);

}  // namespace teleop::analysis
