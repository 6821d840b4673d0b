// The delay demonstration of docs/stability.md ("Time-domain passivity"), lock-step on the loopback plant: with
// K_p = 300 N/m, K_d = 1 N·s/m on the paper's §4.1 devices at 1 kHz, the plain law is bounded up to 6 samples of
// one-way delay and oscillates with a growing amplitude from 7 on; with the passivity controller (either mode) the
// same pair stays bounded at 7 and above, and the network (laws + link + controllers) never generates more than
// a trace of energy. `passivity-delay-sweep` prints the whole table.

#include <gtest/gtest.h>

#include <string>

#include "test_utilities/passivity_sweep.hpp"

namespace teleop::test {
namespace {

using control::PassivityMode;

constexpr int kFirstFailingDelay = 7;  // samples per direction; docs/stability.md quotes it

TEST(PassivityDelay, PlainLawIsBoundedBelowTheFailingDelay) {
  const PassivityDelaySetup setup;
  for (int d = 0; d < kFirstFailingDelay; ++d) {
    const PassivityDelayResult r = RunPassivityDelay(setup, d, PassivityMode::kOff);
    EXPECT_FALSE(r.unstable()) << "delay " << d << ": growth " << r.growth;
    EXPECT_LT(r.late_tracking_rms_m, 0.5e-3) << "delay " << d;
  }
}

TEST(PassivityDelay, PlainLawOscillatesWithGrowingAmplitudeAtTheFailingDelay) {
  const PassivityDelaySetup setup;
  const PassivityDelayResult r = RunPassivityDelay(setup, kFirstFailingDelay, PassivityMode::kOff);
  EXPECT_TRUE(r.unstable());
  EXPECT_GT(r.early_amplitude_m, 5e-3);  // already 5 mm peak-to-peak in [0.5, 1) s...
  EXPECT_TRUE(r.diverged || r.late_amplitude_m > 10.0 * r.early_amplitude_m);  // ... and growing without bound
  EXPECT_LT(r.min_network_energy_J, -1.0);  // the delayed coupling generated more than 1 J
}

TEST(PassivityDelay, PassiveLawIsBoundedAtAndAboveTheFailingDelay) {
  const PassivityDelaySetup setup;
  for (const PassivityMode mode : {PassivityMode::kObserver, PassivityMode::kEnergyExchange}) {
    for (int d = kFirstFailingDelay; d <= 2 * kFirstFailingDelay; ++d) {
      const PassivityDelayResult r = RunPassivityDelay(setup, d, mode);
      SCOPED_TRACE(std::string(control::ToString(mode)) + ", delay " + std::to_string(d));
      EXPECT_FALSE(r.unstable()) << "growth " << r.growth;
      EXPECT_LT(r.late_amplitude_m, 10e-3);
      EXPECT_LT(r.growth, 1.5);
      // Passive network: at most a trace of generated energy (the one-interval prediction of the first steps).
      EXPECT_GT(r.min_network_energy_J, -0.1e-3);
      EXPECT_GT(r.acting_cycles, 0u);
      EXPECT_GT(r.dissipated_J, 0.0);
    }
  }
}

TEST(PassivityDelay, EnergyExchangeKeepsThePlainLawsTrackingWhereThatIsStable) {
  const PassivityDelaySetup setup;
  for (int d = 1; d < kFirstFailingDelay; ++d) {
    const PassivityDelayResult plain = RunPassivityDelay(setup, d, PassivityMode::kOff);
    const PassivityDelayResult exchange = RunPassivityDelay(setup, d, PassivityMode::kEnergyExchange);
    const PassivityDelayResult observer = RunPassivityDelay(setup, d, PassivityMode::kObserver);
    EXPECT_NEAR(exchange.late_tracking_rms_m, plain.late_tracking_rms_m, 0.02 * plain.late_tracking_rms_m)
        << "delay " << d;
    EXPECT_NEAR(exchange.late_master_pp_m, plain.late_master_pp_m, 0.02 * plain.late_master_pp_m) << "delay " << d;
    // The local observer alone is conservative: the slave may return only what it absorbed, so it drags on the
    // master (the operator moves it far less) and tracks worse.
    EXPECT_LT(observer.late_master_pp_m, 0.5 * plain.late_master_pp_m) << "delay " << d;
    EXPECT_GT(observer.late_tracking_rms_m, plain.late_tracking_rms_m) << "delay " << d;
  }
}

TEST(PassivityDelay, SweepFindsTheFirstFailingDelay) {
  const auto results =
      SweepPassivityDelay(PassivityDelaySetup{}, 0, 10, {PassivityMode::kOff, PassivityMode::kEnergyExchange});
  EXPECT_EQ(FirstUnstableDelay(results, PassivityMode::kOff), kFirstFailingDelay);
  EXPECT_EQ(FirstUnstableDelay(results, PassivityMode::kEnergyExchange), -1);
}

}  // namespace
}  // namespace teleop::test
