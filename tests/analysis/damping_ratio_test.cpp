// Eqs. 30-31: z-plane eigenvalue → s-plane → damping ratio.

#include "teleop/analysis/damping_ratio.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>

namespace teleop::analysis {
namespace {

TEST(DampingRatio, RecoversTheDampingOfAContinuousPole) {
  const double t = 1e-3;
  for (double zeta : {-0.3, -0.01, 0.0, 0.05, 0.4, 0.9}) {
    const double wn = 2.0 * std::numbers::pi * 40.0;
    const std::complex<double> s(-zeta * wn, wn * std::sqrt(1.0 - zeta * zeta));
    EXPECT_NEAR(DampingRatio(std::exp(s * t), t), zeta, 1e-9) << zeta;
    EXPECT_NEAR(DampingRatio(std::exp(std::conj(s) * t), t), zeta, 1e-9) << zeta;
  }
}

TEST(DampingRatio, RealAndZeroEigenvalues) {
  EXPECT_DOUBLE_EQ(DampingRatio({0.5, 0.0}, 1e-3), 1.0);   // decaying real pole
  EXPECT_DOUBLE_EQ(DampingRatio({1.5, 0.0}, 1e-3), -1.0);  // growing real pole
  EXPECT_DOUBLE_EQ(DampingRatio({0.0, 0.0}, 1e-3), 1.0);   // pure delay
  // z = -0.5: s = (ln 0.5 + iπ)/T, an oscillation at Nyquist.
  EXPECT_NEAR(DampingRatio({-0.5, 0.0}, 1e-3), std::sin(std::atan(-std::log(0.5) / std::numbers::pi)), 1e-12);
  EXPECT_LT(DampingRatio({-1.01, 0.0}, 1e-3), 0.0);
}

TEST(AnalyzeEigenvalues, SpectralRadiusAndMinimumDampingOfADiagonalModel) {
  StateMatrix a = StateMatrix::Zero();
  const double t = 2e-3;
  const std::complex<double> z = std::exp(std::complex<double>(-5.0, 300.0) * t);
  // A 2×2 real block with eigenvalues z, z̄.
  a(0, 0) = z.real();
  a(0, 1) = -z.imag();
  a(1, 0) = z.imag();
  a(1, 1) = z.real();
  a(2, 2) = 0.9;
  const ModalSummary modes = AnalyzeEigenvalues(a, t);
  EXPECT_NEAR(modes.spectral_radius, std::abs(z), 1e-12);  // e^{-5·T} = 0.990 > 0.9
  EXPECT_NEAR(modes.min_damping_ratio, 5.0 / std::hypot(5.0, 300.0), 1e-9);
  EXPECT_NEAR(std::abs(modes.dominant_z), std::abs(z), 1e-12);
  EXPECT_NEAR(SpectralRadius(a), std::abs(z), 1e-12);
}

}  // namespace
}  // namespace teleop::analysis
