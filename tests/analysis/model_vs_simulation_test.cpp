// The discrete model's eigenvalues against an independent fine-step simulation of the same sampled system
// (tests/analysis/sampled_simulation.hpp): just below the predicted limit a perturbation decays, just above it
// grows, and the growth per sample matches the model's largest |z|.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <optional>
#include <string>
#include <vector>

#include "analysis/sampled_simulation.hpp"
#include "teleop/analysis/damping_ratio.hpp"
#include "teleop/analysis/discrete_model.hpp"
#include "teleop/analysis/human_bounds.hpp"
#include "teleop/analysis/stability_limit.hpp"

namespace teleop::analysis {
namespace {

struct Case {
  std::string name;
  FixtureSide side;
  double rate_hz;
  LawGains gains;
  bool unilateral = false;
  int delay = 0;
  double filter_hz = 0.0;
  double delay_fraction = 0.0;                          ///< peer_delay_fraction (with delay = 0)
  std::optional<double> slave_fraction = std::nullopt;  ///< slave_peer_delay_fraction: a triggered pair
};

std::ostream& operator<<(std::ostream& out, const Case& c) { return out << c.name; }

LawGains Gains(double kp, double kd, double kv = 0.0) {
  LawGains g = LawGains::Symmetric(kp, kd);
  g.kvm_Ns_per_m = g.kvs_Ns_per_m = kv;
  return g;
}

// K_vm and K_vs set apart: a wiring slip that swaps or drops one of them moves the limit of one side only.
LawGains Damped(double kp, double kd, double kvm, double kvs) {
  LawGains g = LawGains::Symmetric(kp, kd);
  g.kvm_Ns_per_m = kvm;
  g.kvs_Ns_per_m = kvs;
  return g;
}

LawGains SlaveOnly(double kps, double kds) {
  LawGains g;
  g.kps_N_per_m = kps;
  g.kds_Ns_per_m = kds;
  return g;
}

// Envelope growth per sample measured on the simulation: max magnitude over the last window against the max over
// a window after the start transient.
struct Measured {
  double growth_per_sample = 0.0;
  double start_envelope = 0.0;
  double end_envelope = 0.0;
};

Measured Simulate(const SampledTeleoperator& system, const LawGains& gains, const HumanModel& human, int samples,
                  int window) {
  test::SampledSimulation sim(system, gains, human);
  sim.Perturb(1e-4, -1e-3);
  std::vector<double> magnitude(static_cast<std::size_t>(samples));
  for (int k = 0; k < samples; ++k) {
    sim.Step();
    magnitude[static_cast<std::size_t>(k)] = sim.Magnitude();
  }
  const int start = samples / 5;
  auto envelope = [&](int from) {
    return *std::max_element(magnitude.begin() + from, magnitude.begin() + from + window);
  };
  Measured m;
  m.start_envelope = envelope(start);
  m.end_envelope = envelope(samples - window);
  m.growth_per_sample = std::pow(m.end_envelope / m.start_envelope, 1.0 / (samples - window - start));
  return m;
}

class ModelVsSimulation : public ::testing::TestWithParam<Case> {};

TEST_P(ModelVsSimulation, PerturbationDecaysBelowAndGrowsAboveThePredictedLimit) {
  const Case& c = GetParam();
  SampledTeleoperator system;
  system.rate_hz = c.rate_hz;
  system.gains = c.gains;
  system.unilateral = c.unilateral;
  system.peer_delay_samples = c.delay;
  system.velocity_filter_hz = c.filter_hz;
  system.peer_delay_fraction = c.delay_fraction;
  system.slave_peer_delay_fraction = c.slave_fraction;
  const std::vector<HumanModel> humans = MakeHumanGrid(DefaultFingerBounds(), 3);
  const StabilityLimit limit = FindMaxStableStiffness(system, c.side, humans);
  ASSERT_FALSE(limit.unstable_without_fixture);
  ASSERT_GT(limit.max_stable_stiffness_N_per_m, 0.0);
  const HumanModel human = limit.limiting_human;

  for (double factor : {0.97, 1.03}) {
    SCOPED_TRACE("stiffness factor " + std::to_string(factor));
    SampledTeleoperator at = system;
    at.gains = EffectiveGains(system, c.side);
    at.gains.fixture(c.side) = factor * limit.max_stable_stiffness_N_per_m;
    const StateMatrix a = BuildStateMatrix(at, human);
    const ModalSummary modes = AnalyzeEigenvalues(a, at.period_s());
    const double rho = modes.spectral_radius;
    if (factor < 1.0) {
      EXPECT_LT(rho, 1.0);
      EXPECT_GT(modes.min_damping_ratio, 0.0);
    } else {
      EXPECT_GT(rho, 1.0);
      EXPECT_LT(modes.min_damping_ratio, 0.0);
    }
    // Long enough for the dominant mode to change the amplitude 30-fold; windows of two oscillation periods.
    const double angle = std::abs(std::arg(modes.dominant_z));
    const int period_samples = angle > 1e-3 ? static_cast<int>(std::ceil(2.0 * 3.14159265 / angle)) : 50;
    const int window = std::max(20, 2 * period_samples);
    const int samples =
        std::clamp(static_cast<int>(std::log(30.0) / std::abs(std::log(rho))) + 5 * window, 2000, 400000);
    const Measured m = Simulate(at, at.gains, human, samples, window);
    if (factor < 1.0) {
      EXPECT_LT(m.end_envelope, 0.2 * m.start_envelope) << "did not decay";
    } else {
      EXPECT_GT(m.end_envelope, 5.0 * m.start_envelope) << "did not grow";
    }
    // Growth rate per sample agrees with |z|max: within 10 % of ln|z| (the envelope is sampled, not exact).
    EXPECT_NEAR(std::log(m.growth_per_sample), std::log(rho), 0.1 * std::abs(std::log(rho)))
        << "rho " << rho << " simulated " << m.growth_per_sample;
  }
}

INSTANTIATE_TEST_SUITE_P(
    RatesGainsSides, ModelVsSimulation,
    ::testing::Values(
        Case{"slave_500Hz_kp600_kd2", FixtureSide::kSlave, 500.0, Gains(600, 2)},
        Case{"slave_1000Hz_kp600_kd2", FixtureSide::kSlave, 1000.0, Gains(600, 2)},
        Case{"slave_2000Hz_kp800_kd6", FixtureSide::kSlave, 2000.0, Gains(800, 6)},
        Case{"master_500Hz_kp600_kd2", FixtureSide::kMaster, 500.0, Gains(600, 2)},
        Case{"master_1000Hz_kp1000_kd4", FixtureSide::kMaster, 1000.0, Gains(1000, 4)},
        Case{"master_250Hz_kp300_kd1_kv0.5", FixtureSide::kMaster, 250.0, Gains(300, 1, 0.5)},
        Case{"slave_unilateral_500Hz", FixtureSide::kSlave, 500.0, SlaveOnly(1000, 6), true},
        Case{"slave_unilateral_1000Hz", FixtureSide::kSlave, 1000.0, SlaveOnly(1000, 6), true},
        Case{"master_unilateral_500Hz", FixtureSide::kMaster, 500.0, SlaveOnly(1000, 6), true},
        Case{"master_unilateral_2000Hz", FixtureSide::kMaster, 2000.0, SlaveOnly(1000, 6), true},
        Case{"slave_1000Hz_delay1", FixtureSide::kSlave, 1000.0, Gains(600, 2), false, 1},
        Case{"master_1000Hz_delay1", FixtureSide::kMaster, 1000.0, Gains(600, 2), false, 1},
        Case{"slave_1000Hz_filter200", FixtureSide::kSlave, 1000.0, Gains(600, 2), false, 0, 200.0},
        Case{"master_2000Hz_delay1_filter200", FixtureSide::kMaster, 2000.0, Gains(600, 2), false, 1, 200.0},
        Case{"slave_1000Hz_kvs1", FixtureSide::kSlave, 1000.0, Damped(600, 2, 0, 1)},
        Case{"slave_1000Hz_kvm2_delay1", FixtureSide::kSlave, 1000.0, Damped(600, 2, 2, 0), false, 1},
        Case{"master_500Hz_kvm1", FixtureSide::kMaster, 500.0, Damped(600, 2, 1, 0)},
        Case{"master_1000Hz_kvs2_delay1_filter200", FixtureSide::kMaster, 1000.0, Damped(600, 2, 0, 2), false, 1,
             200.0},
        Case{"slave_2000Hz_kv0.5_1.5_delay1_filter200", FixtureSide::kSlave, 2000.0, Damped(800, 4, 0.5, 1.5), false, 1,
             200.0},
        // Fractional peer delay (ZOH with the peer terms split at τ): a phase-locked pair.
        Case{"slave_1000Hz_frac0.05", FixtureSide::kSlave, 1000.0, Gains(600, 2), false, 0, 0.0, 0.05},
        Case{"slave_1000Hz_frac0.5", FixtureSide::kSlave, 1000.0, Gains(600, 2), false, 0, 0.0, 0.5},
        Case{"master_1000Hz_frac0.3", FixtureSide::kMaster, 1000.0, Gains(600, 2), false, 0, 0.0, 0.3},
        Case{"slave_2000Hz_kvm2_frac0.7_filter200", FixtureSide::kSlave, 2000.0, Damped(800, 4, 2, 0), false, 0, 200.0,
             0.7},
        // A triggered pair (sync.mode triggered): the master sees the slave's reply one sample late,
        // the slave sees the master's sample a fraction late (the process's start-up model).
        Case{"slave_1000Hz_triggered0.1", FixtureSide::kSlave, 1000.0, Gains(600, 2), false, 1, 0.0, 0.0, 0.1},
        Case{"master_1000Hz_triggered0.1", FixtureSide::kMaster, 1000.0, Gains(600, 2), false, 1, 0.0, 0.0, 0.1},
        Case{"slave_4000Hz_kvs1_triggered0.4_filter200", FixtureSide::kSlave, 4000.0, Damped(800, 4, 0, 1), false, 1,
             200.0, 0.0, 0.4}),
    [](const ::testing::TestParamInfo<Case>& param_info) {
      std::string name = param_info.param.name;
      std::replace(name.begin(), name.end(), '.', '_');
      return name;
    });

}  // namespace
}  // namespace teleop::analysis
