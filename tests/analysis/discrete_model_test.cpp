// The pieces of the discrete model: the exact ZOH discretization, the structure of A, validation.

#include "teleop/analysis/discrete_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <optional>

#include "teleop/analysis/damping_ratio.hpp"
#include "teleop/analysis/state_eigen_solver.hpp"
#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::analysis {
namespace {

TEST(ZohDiscretization, MassDamperUnderConstantForceMatchesTheClosedForm) {
  // m ẍ + b ẋ = u from rest: x(T) = u/b·(T - τ(1 - e^{-T/τ})), v(T) = u/b·(1 - e^{-T/τ}), τ = m/b.
  const double m = 0.036, b = 0.49, u = 2.0, t = 0.002;
  const ZohBlock block = DiscretizeMassSpringDamper(m, b, 0.0, t);
  const double tau = m / b;
  EXPECT_NEAR(block.gamma(0) * u, u / b * (t - tau * (1.0 - std::exp(-t / tau))), 1e-15);
  EXPECT_NEAR(block.gamma(1) * u, u / b * (1.0 - std::exp(-t / tau)), 1e-13);
  EXPECT_NEAR(block.phi(0, 0), 1.0, 1e-15);
  EXPECT_NEAR(block.phi(1, 1), std::exp(-t / tau), 1e-13);
}

TEST(ZohDiscretization, SpringMassDamperEigenvaluesAreExpOfContinuousPoles) {
  const double m = 0.045, b = 1.2, k = 300.0, t = 0.001;
  const ZohBlock block = DiscretizeMassSpringDamper(m, b, k, t);
  const std::complex<double> s(-b / (2 * m), std::sqrt(k / m - b * b / (4 * m * m)));
  const std::complex<double> z = std::exp(s * t);
  // The eigenvalues of the 2×2 phi in closed form, the roots of λ² - tr·λ + det (Eigen's solver instantiated for a
  // fixed 2×2 costs more compile time than the rest of this file).
  const double half_trace = block.phi.trace() / 2.0;
  const double det = block.phi(0, 0) * block.phi(1, 1) - block.phi(0, 1) * block.phi(1, 0);
  const std::complex<double> root = std::sqrt(std::complex<double>(half_trace * half_trace - det));
  const double err = std::min(std::abs(half_trace + root - z), std::abs(half_trace - root - z));
  EXPECT_LT(err, 1e-12);
  // Static gain: a held force u settles at x = u/k, so (I - phi)^-1 gamma = [1/k, 0].
  const Eigen::Vector2d settle = (Eigen::Matrix2d::Identity() - block.phi).inverse() * block.gamma;
  EXPECT_NEAR(settle(0), 1.0 / k, 1e-9);
  EXPECT_NEAR(settle(1), 0.0, 1e-9);
}

TEST(StateMatrix, PaperModelHasTwoZeroEigenvaluesAndSixOthers) {
  // §3.2: "The model has eight eigenvalues, but two of them are identically equal to zero". Without filter and
  // delay our two extra states (previous velocity estimates) give exactly these two zeros. (With K_vm = K_vs = 0
  // the law only uses the velocity difference, and the sum of the previous positions adds a third, harmless zero;
  // the local damping here avoids that.)
  SampledTeleoperator system;
  system.rate_hz = 500.0;
  system.gains = LawGains::Symmetric(800.0, 6.0);
  system.gains.kvm_Ns_per_m = 0.2;
  system.gains.kvs_Ns_per_m = 0.5;
  system.gains.slave_fixture_N_per_m = 2000.0;
  const StateMatrix a = BuildStateMatrix(system, HumanModel{0.006, 1.5, 300.0, 5.0});
  Eigen::EigenSolver<StateMatrix> solver(a, false);
  int zeros = 0;
  for (int i = 0; i < kModelStates; ++i) zeros += std::abs(solver.eigenvalues()(i)) < 1e-6 ? 1 : 0;
  EXPECT_EQ(zeros, 2);
  // The columns of the two velocity-memory states are zero.
  EXPECT_EQ(a.col(6).norm(), 0.0);
  EXPECT_EQ(a.col(7).norm(), 0.0);
}

TEST(StateMatrix, DelayAndFilterUseTheMemoryStates) {
  SampledTeleoperator system;
  system.gains = LawGains::Symmetric(600.0, 2.0);
  system.peer_delay_samples = 1;
  const StateMatrix delayed = BuildStateMatrix(system, HumanModel{0.006, 1.5, 300.0, 5.0});
  EXPECT_GT(delayed.col(7).norm(), 0.0);  // the master's law uses the slave's previous velocity estimate
  system.peer_delay_samples = 0;
  system.velocity_filter_hz = 200.0;
  const StateMatrix filtered = BuildStateMatrix(system, HumanModel{0.006, 1.5, 300.0, 5.0});
  const double a = VelocityFilterCoefficient(200.0, 1e-3);
  EXPECT_NEAR(a, 1.0 - std::exp(-2.0 * 3.141592653589793 * 0.2), 1e-15);
  EXPECT_NEAR(filtered(6, 6), 1.0 - a, 1e-15);  // y_m(k) = (1-a)·y_m(k-1) + a·(X_m(k) - X_m(k-1))/T
  EXPECT_NEAR(filtered(6, 0), a / 1e-3, 1e-9);
}

TEST(StateMatrix, AssembleDoesNotAllocate) {
  SampledTeleoperator system;
  system.gains = LawGains::Symmetric(600.0, 2.0);
  const ZohBlock master = DiscretizeMasterWithHuman(system, HumanModel{0.006, 1.5, 300.0, 5.0});
  const ZohBlock slave = DiscretizeSlave(system);
  teleop::test::AllocationCounter counter;
  const StateMatrix a = AssembleStateMatrix(system, master, slave);
  const double radius = SpectralRadius(a);
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_LT(radius, 1.0);
}

TEST(Validation, BadSystemsThrowNamingTheField) {
  const HumanModel human{0.006, 1.5, 300.0, 5.0};
  auto message = [&](const SampledTeleoperator& s) -> std::string {
    try {
      (void)BuildStateMatrix(s, human);
    } catch (const Error& e) {
      return e.what();
    }
    return "no error";
  };
  SampledTeleoperator s;
  s.master.mass_kg = 0.0;
  EXPECT_NE(message(s).find("master mass_kg"), std::string::npos);
  s = {};
  s.rate_hz = std::nan("");
  EXPECT_NE(message(s).find("rate_hz"), std::string::npos);
  s = {};
  s.peer_delay_samples = kMaxPeerDelaySamples + 1;
  EXPECT_NE(message(s).find("peer_delay_samples"), std::string::npos);
  s = {};
  s.peer_delay_samples = 2;  // valid, but beyond the 8 states: the delay-line model's
  EXPECT_NE(message(s).find("delay-line model"), std::string::npos);
  s = {};
  s.slave_peer_delay_samples = -1;
  EXPECT_NE(message(s).find("slave_peer_delay_samples"), std::string::npos);
  s = {};
  s.velocity_filter_hz = 600.0;  // above Nyquist at 1 kHz
  EXPECT_NE(message(s).find("Nyquist"), std::string::npos);
  s = {};
  s.gains.slave_fixture_N_per_m = -1.0;
  EXPECT_NE(message(s).find("slave fixture"), std::string::npos);
  s = {};
  EXPECT_THROW((void)BuildStateMatrix(s, HumanModel{0.0, 1.0, 1.0, 0.0}), Error);
  EXPECT_THROW((void)BuildStateMatrix(s, HumanModel{0.01, -1.0, 1.0, 0.0}), Error);
}

// The delay-line model (any delay) against the 8-state one where both apply: the same spectral radius (the lines
// only add zero eigenvalues), for the paper's model, a fraction, one sample, and a triggered pair.
TEST(DelayLineModel, MatchesTheEightStateModelWhereBothApply) {
  const HumanModel human{0.003, 0.62, 230.0, 2.0};
  SampledTeleoperator base;
  base.gains = LawGains::Symmetric(600.0, 2.0);
  base.gains.slave_fixture_N_per_m = 3000.0;
  base.velocity_filter_hz = 200.0;
  struct Case {
    int samples;
    double fraction;
    std::optional<double> slave_fraction;
    int dimension;
  };
  for (const Case& c : {Case{0, 0.0, std::nullopt, 8}, Case{0, 0.4, std::nullopt, 10}, Case{1, 0.0, std::nullopt, 10},
                        Case{1, 0.0, 0.1, 10}}) {
    SampledTeleoperator s = base;
    s.peer_delay_samples = c.samples;
    s.peer_delay_fraction = c.fraction;
    s.slave_peer_delay_fraction = c.slave_fraction;
    ASSERT_FALSE(NeedsDelayLines(s));
    EXPECT_EQ(DelayedStateDimension(s), c.dimension);
    const double eight = SpectralRadius(BuildStateMatrix(s, human));
    const Eigen::MatrixXd lines = BuildDelayedStateMatrix(s, human);
    EXPECT_EQ(lines.rows(), c.dimension);
    EXPECT_NEAR(SpectralRadius(lines), eight, 1e-9) << c.samples << " + " << c.fraction;
  }
}

// Whole-sample delays enter a scalar loop (master -> line -> slave -> line -> master): the characteristic polynomial
// depends on the round trip d_sm + d_ms only, so 3 + 7 and 5 + 5 have the same eigenvalues; a fraction on one
// direction does not commute (it acts through that side's plant). The dimension is 8 + the lines' lengths.
TEST(DelayLineModel, WholeSampleDelaysCountAsTheRoundTrip) {
  const HumanModel human{0.003, 0.62, 230.0, 2.0};
  SampledTeleoperator s;
  s.gains = LawGains::Symmetric(100.0, 1.0);
  s.gains.slave_fixture_N_per_m = 1000.0;
  SetPeerDelays(s, 3.0, 7.0);
  ASSERT_TRUE(NeedsDelayLines(s));
  EXPECT_EQ(DelayedStateDimension(s), 8 + 3 + 7);
  const double a = SpectralRadius(BuildDelayedStateMatrix(s, human));
  SetPeerDelays(s, 5.0, 5.0);
  const double b = SpectralRadius(BuildDelayedStateMatrix(s, human));
  EXPECT_NEAR(a, b, 1e-9);
  SetPeerDelays(s, 40.5, 10.0);
  EXPECT_EQ(DelayedStateDimension(s), 8 + 41 + 10);
  EXPECT_EQ(PeerDelaysOf(s).slave_to_master_samples, 40);
  EXPECT_DOUBLE_EQ(PeerDelaysOf(s).slave_to_master_fraction, 0.5);
  EXPECT_EQ(DescribePeerDelay(s), "peer delay slave->master 40.5 samples, master->slave 10 samples");
  // A link delay adds to both directions: 1 sample + 4.25 ms at 1 kHz.
  SampledTeleoperator t;
  t.peer_delay_samples = 1;
  AddLinkDelay(t, 4.25e-3);
  EXPECT_DOUBLE_EQ(PeerDelaysOf(t).slave_to_master(), 5.25);
  EXPECT_DOUBLE_EQ(PeerDelaysOf(t).master_to_slave(), 5.25);
  EXPECT_THROW(AddLinkDelay(t, 1.0), Error);  // 1000 samples, beyond the bound
}

}  // namespace
}  // namespace teleop::analysis
