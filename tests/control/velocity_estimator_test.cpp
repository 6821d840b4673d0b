#include "teleop/control/velocity_estimator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "teleop/error.hpp"

namespace teleop::control {
namespace {

DofVector One(double x) { return DofVector::Constant(1, x); }

TEST(VelocityEstimator, FirstSampleGivesZeroThenBackwardDifference) {
  VelocityEstimator estimator({1, 0.0});
  const double period_s = 0.001;
  EXPECT_EQ(estimator.Step(One(0.5), period_s)[0], 0.0);  // primed, not a jump from the origin
  EXPECT_NEAR(estimator.Step(One(0.501), period_s)[0], 1.0, 1e-9);
  EXPECT_NEAR(estimator.Step(One(0.503), period_s)[0], 2.0, 1e-9);
  EXPECT_NEAR(estimator.Step(One(0.503), period_s)[0], 0.0, 1e-12);
}

TEST(VelocityEstimator, CutoffZeroIsExactlyTheRawDifference) {
  VelocityEstimator estimator({2, 0.0});
  const double period_s = 0.0025;
  DofVector previous(2);
  previous << 0.0, 0.0;
  (void)estimator.Step(previous, period_s);
  for (int k = 1; k < 200; ++k) {
    DofVector x(2);
    x << 0.01 * std::sin(0.37 * k), -0.02 * std::cos(0.11 * k * k);
    const DofVector& v = estimator.Step(x, period_s);
    EXPECT_EQ(v[0], (x[0] - previous[0]) / period_s);
    EXPECT_EQ(v[1], (x[1] - previous[1]) / period_s);
    previous = x;
  }
}

TEST(VelocityEstimator, FilteredStepResponseMatchesTheDiscreteFirstOrderResponse) {
  // A position ramp at v0 from k = 0 is a velocity step for the filter: y(k) = v0·(1 - (1 - a)^k).
  const double cutoff_hz = 200.0;
  const double period_s = 0.001;
  const double v0 = 0.25;
  VelocityEstimator estimator({1, cutoff_hz});
  const double a = 1.0 - std::exp(-2.0 * std::numbers::pi * cutoff_hz * period_s);
  EXPECT_NEAR(estimator.FilterCoefficient(period_s), a, 1e-15);
  EXPECT_NEAR(a, 0.7153905, 1e-6);  // 1 - exp(-0.4π)
  (void)estimator.Step(One(0.0), period_s);
  for (int k = 1; k <= 30; ++k) {
    const double expected = v0 * (1.0 - std::pow(1.0 - a, k));
    EXPECT_NEAR(estimator.Step(One(v0 * k * period_s), period_s)[0], expected, 1e-12) << "k = " << k;
  }
}

TEST(VelocityEstimator, LowCutoffSettlesAtTheTimeConstant) {
  // After one time constant τ = 1/(2π f_c) of samples the response is 1 - e^-1 of the step (exact discretisation).
  const double cutoff_hz = 10.0;
  const double period_s = 1.0 / (2.0 * std::numbers::pi * cutoff_hz) / 100.0;  // τ = 100 samples
  VelocityEstimator estimator({1, cutoff_hz});
  (void)estimator.Step(One(0.0), period_s);
  double y = 0.0;
  for (int k = 1; k <= 100; ++k) y = estimator.Step(One(1.0 * k * period_s), period_s)[0];
  EXPECT_NEAR(y, 1.0 - std::exp(-1.0), 1e-12);
}

TEST(VelocityEstimator, BadSamplesLeaveTheStateUnchanged) {
  VelocityEstimator estimator({1, 0.0});
  (void)estimator.Step(One(0.0), 0.001);
  EXPECT_NEAR(estimator.Step(One(0.001), 0.001)[0], 1.0, 1e-9);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NEAR(estimator.Step(One(nan), 0.001)[0], 1.0, 1e-9);
  EXPECT_NEAR(estimator.Step(One(0.5), 0.0)[0], 1.0, 1e-9);
  EXPECT_NEAR(estimator.Step(One(0.5), nan)[0], 1.0, 1e-9);
  EXPECT_NEAR(estimator.Step(DofVector::Zero(2), 0.001)[0], 1.0, 1e-9);
  EXPECT_TRUE(estimator.state().velocity_m_per_s.allFinite());
  EXPECT_NEAR(estimator.Step(One(0.003), 0.001)[0], 2.0, 1e-9);  // continues from the last good sample
  estimator.Reset();
  EXPECT_FALSE(estimator.state().primed);
  EXPECT_EQ(estimator.Step(One(0.7), 0.001)[0], 0.0);
}

TEST(VelocityEstimator, RejectsBadConfig) {
  EXPECT_THROW(VelocityEstimator({0, 0.0}), Error);
  EXPECT_THROW(VelocityEstimator({kMaxDof + 1, 0.0}), Error);
  EXPECT_THROW(VelocityEstimator({1, -1.0}), Error);
  EXPECT_THROW(VelocityEstimator({1, std::numeric_limits<double>::infinity()}), Error);
}

}  // namespace
}  // namespace teleop::control
