#include "teleop/analysis/damping_ratio.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "teleop/analysis/state_eigen_solver.hpp"

// The one instantiation of the state matrix's eigen solver (state_eigen_solver.hpp): compute(), where the work is.
template Eigen::EigenSolver<teleop::analysis::StateMatrix>&
Eigen::EigenSolver<teleop::analysis::StateMatrix>::compute<teleop::analysis::StateMatrix>(
    const Eigen::EigenBase<teleop::analysis::StateMatrix>& matrix, bool computeEigenvectors);

template Eigen::EigenSolver<Eigen::MatrixXd>& Eigen::EigenSolver<Eigen::MatrixXd>::compute<Eigen::MatrixXd>(
    const Eigen::EigenBase<Eigen::MatrixXd>& matrix, bool computeEigenvectors);

namespace teleop::analysis {
namespace {

// Eigenvalues closer to the origin than this are pure delays (their s-plane image is at -∞).
constexpr double kZeroEigenvalue = 1e-12;

}  // namespace

double DampingRatio(std::complex<double> z, double period_s) noexcept {
  if (std::abs(z) < kZeroEigenvalue) return 1.0;
  const std::complex<double> s = std::log(z) / period_s;       // eq. 30, principal branch
  return std::sin(std::atan2(-s.real(), std::abs(s.imag())));  // eq. 31
}

namespace {

template <typename Matrix>
ModalSummary Analyze(const Matrix& a, double period_s) {
  Eigen::EigenSolver<Matrix> solver(a, /*computeEigenvectors=*/false);
  ModalSummary summary;
  if (solver.info() != Eigen::Success) {
    // Does not happen for finite matrices; report "unstable" rather than a false "stable".
    summary.spectral_radius = std::numeric_limits<double>::infinity();
    summary.min_damping_ratio = -1.0;
    return summary;
  }
  for (Eigen::Index i = 0; i < a.rows(); ++i) {
    const std::complex<double> z = solver.eigenvalues()(i);
    summary.spectral_radius = std::max(summary.spectral_radius, std::abs(z));
    const double zeta = DampingRatio(z, period_s);
    if (zeta < summary.min_damping_ratio || i == 0) {
      summary.min_damping_ratio = zeta;
      summary.dominant_z = z;
    }
  }
  return summary;
}

template <typename Matrix>
double Radius(const Matrix& a) {
  Eigen::EigenSolver<Matrix> solver(a, /*computeEigenvectors=*/false);
  if (solver.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return solver.eigenvalues().cwiseAbs().maxCoeff();
}

}  // namespace

ModalSummary AnalyzeEigenvalues(const StateMatrix& a, double period_s) noexcept { return Analyze(a, period_s); }
ModalSummary AnalyzeEigenvalues(const Eigen::MatrixXd& a, double period_s) { return Analyze(a, period_s); }

double SpectralRadius(const StateMatrix& a) noexcept { return Radius(a); }
double SpectralRadius(const Eigen::MatrixXd& a) { return Radius(a); }

}  // namespace teleop::analysis
