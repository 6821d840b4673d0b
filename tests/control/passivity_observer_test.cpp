// PassivityController: the observer's energies on known power sequences, the controller dissipating exactly the
// deficit and never adding energy, its bounds, the energy-exchange credit, bad input, no allocation.

#include "teleop/control/passivity_observer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::control {
namespace {

constexpr double kT = 0.001;

PassivityController::Config Make(PassivityMode mode, int dof = 1, double max_damping = 1e6) {
  PassivityController::Config config;
  config.mode = mode;
  config.dof = dof;
  config.max_damping_Ns_per_m = DofVector::Constant(dof, max_damping);
  return config;
}

PassivityController::Input In(double u, double v) {
  PassivityController::Input in;
  in.force_N = DofVector::Constant(1, u);
  in.velocity_m_per_s = DofVector::Constant(1, v);
  in.peer_input_energy_J = DofVector::Zero(1);
  return in;
}

TEST(PassivityController, ObserverAccumulatesPortEnergyInAndOut) {
  PassivityController pc(Make(PassivityMode::kOff));
  // Absorb 2 N · -0.5 m/s for 10 steps: E_in = 10 · 1 W · 1 ms = 10 mJ; then deliver 1 N · 0.5 m/s for 4 steps.
  for (int k = 0; k < 10; ++k) (void)pc.Step(In(2.0, -0.5), kT);
  for (int k = 0; k < 4; ++k) (void)pc.Step(In(1.0, 0.5), kT);
  EXPECT_NEAR(pc.state().input_energy_J[0], 10e-3, 1e-15);
  EXPECT_NEAR(pc.state().output_energy_J[0], 2e-3, 1e-15);
  EXPECT_NEAR(pc.state().observed_J[0], 8e-3, 1e-15);
  EXPECT_EQ(pc.state().acting_steps, 0u);
}

TEST(PassivityController, OffModeObservesTheDeficitButNeverChangesTheCommand) {
  PassivityController pc(Make(PassivityMode::kOff));
  for (int k = 0; k < 5; ++k) {
    const auto out = pc.Step(In(3.0, 0.2), kT);
    EXPECT_EQ(out.force_N[0], 3.0);
    EXPECT_FALSE(out.acted);
  }
  EXPECT_NEAR(pc.state().observed_J[0], -5 * 0.6e-3, 1e-15);
  EXPECT_NEAR(pc.state().min_observed_J, -3e-3, 1e-15);
}

// A known active sequence: the port first absorbs 5 mJ, then the law tries to deliver 0.6 W for 20 ms (12 mJ).
// The controller lets the first 5 mJ through and dissipates exactly the 7 mJ beyond, so the port's net delivered
// energy Σ u'·v·T never exceeds what it absorbed.
TEST(PassivityController, ObserverDissipatesExactlyTheActiveEnergy) {
  PassivityController pc(Make(PassivityMode::kObserver));
  for (int k = 0; k < 5; ++k) (void)pc.Step(In(-2.0, 0.5), kT);  // absorbs 1 mJ per step
  double net_delivered_J = -5e-3;
  for (int k = 0; k < 20; ++k) {
    const auto out = pc.Step(In(3.0, 0.2), kT);
    net_delivered_J += out.force_N[0] * 0.2 * kT;
    EXPECT_LE(net_delivered_J, 1e-15) << "step " << k;
    EXPECT_GE(pc.state().observed_J[0], 0.0);
    EXPECT_GE(out.damping_Ns_per_m[0], 0.0);
  }
  EXPECT_NEAR(pc.state().dissipated_J[0], 12e-3 - 5e-3, 1e-14);
  EXPECT_NEAR(net_delivered_J, 0.0, 1e-14);
  EXPECT_NEAR(pc.state().observed_J[0], 0.0, 1e-15);
  // The first 8 delivering steps (8 · 0.6 mJ = 4.8 mJ) fit in the 5 mJ; the controller acts from the 9th on.
  EXPECT_EQ(pc.state().acting_steps, 12u);
}

TEST(PassivityController, SeededRandomSequencesNeverAddEnergy) {
  const int count = 2000;  // raise to search harder
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> force(-5.0, 5.0);
  std::uniform_real_distribution<double> velocity(-0.3, 0.3);
  for (const PassivityMode mode : {PassivityMode::kObserver, PassivityMode::kEnergyExchange}) {
    PassivityController pc(Make(mode, 1, 1e9));
    double peer_in = 0.0;
    double net_in_J = 0.0;  // energy absorbed by network + controller from the device (observer: must stay ≥ 0)
    for (int k = 0; k < count; ++k) {
      auto in = In(force(rng), velocity(rng));
      peer_in += 0.1e-3 * std::fabs(velocity(rng));
      in.peer_input_energy_J[0] = peer_in;
      in.peer_energy_valid = true;
      const auto out = pc.Step(in, kT);
      const double u = in.force_N[0];
      const double v = in.velocity_m_per_s[0];
      // Never adds energy: the damper's force opposes the velocity, the delivered power only ever goes down.
      EXPECT_GE(out.damping_Ns_per_m[0], 0.0);
      EXPECT_LE(out.force_N[0] * v, u * v + 1e-15);
      net_in_J -= out.force_N[0] * v * kT;
      const double credit = mode == PassivityMode::kObserver ? 0.0 : peer_in;
      if (mode == PassivityMode::kObserver) {
        EXPECT_GE(net_in_J, -1e-12) << "step " << k;
      }
      EXPECT_GE(pc.state().observed_J[0], -1e-12);
      // Energy delivered beyond what was absorbed never exceeds the credit (the peer's input energy).
      EXPECT_GE(net_in_J + credit, -1e-12) << "step " << k;
    }
  }
}

TEST(PassivityController, EnergyExchangeOutputsOnlyWhatThePeerSupplied) {
  PassivityController pc(Make(PassivityMode::kEnergyExchange));
  // The port itself absorbs 5 mJ: in energy_exchange that is sent to the peer, not credited locally.
  for (int k = 0; k < 5; ++k) (void)pc.Step(In(-2.0, 0.5), kT);
  EXPECT_NEAR(pc.state().input_energy_J[0], 5e-3, 1e-15);
  EXPECT_EQ(pc.state().observed_J[0], 0.0);
  // No peer energy yet: a delivering command is damped to zero net output.
  auto out = pc.Step(In(3.0, 0.2), kT);
  EXPECT_NEAR(out.force_N[0] * 0.2, 0.0, 1e-12);
  // The peer reports 1.2 mJ absorbed: two steps of 0.6 mJ pass untouched, the third is damped.
  auto in = In(3.0, 0.2);
  in.peer_energy_valid = true;
  in.peer_input_energy_J[0] = 1.2e-3;
  out = pc.Step(in, kT);
  EXPECT_NEAR(out.force_N[0], 3.0, 1e-9);
  out = pc.Step(in, kT);  // the same cumulative value again: no new credit
  EXPECT_NEAR(out.force_N[0], 3.0, 1e-9);
  out = pc.Step(in, kT);
  EXPECT_NEAR(out.force_N[0], 0.0, 1e-12);
  // A restarted peer (its E_in back near 0) gives no credit; its next increase does.
  in.peer_input_energy_J[0] = 0.1e-3;
  out = pc.Step(in, kT);
  EXPECT_NEAR(out.force_N[0], 0.0, 1e-12);
  in.peer_input_energy_J[0] = 0.7e-3;
  out = pc.Step(in, kT);
  EXPECT_NEAR(out.force_N[0], 3.0, 1e-9);
  // Three damped steps of 0.6 mJ each: no credit yet, credit used up, restarted peer.
  EXPECT_NEAR(pc.state().dissipated_J[0], 1.8e-3, 1e-15);
}

TEST(PassivityController, DampingBoundCarriesTheDeficitForward) {
  // α ≤ 5 N·s/m: with v = 0.2 m/s the damper takes at most 5·0.04·1e-3 = 0.2 mJ per step.
  PassivityController pc(Make(PassivityMode::kObserver, 1, 5.0));
  auto out = pc.Step(In(3.0, 0.2), kT);  // deficit 0.6 mJ, 0.2 mJ dissipated
  EXPECT_DOUBLE_EQ(out.damping_Ns_per_m[0], 5.0);
  EXPECT_DOUBLE_EQ(out.force_N[0], 2.0);
  EXPECT_NEAR(pc.state().observed_J[0], -0.4e-3, 1e-15);
  EXPECT_EQ(pc.state().saturated_steps, 1u);
  // The law now asks for nothing: the controller keeps dissipating the carried deficit (0.2 mJ a step).
  out = pc.Step(In(0.0, 0.2), kT);
  EXPECT_DOUBLE_EQ(out.force_N[0], -1.0);
  out = pc.Step(In(0.0, 0.2), kT);
  EXPECT_NEAR(pc.state().observed_J[0], 0.0, 1e-15);
  out = pc.Step(In(0.0, 0.2), kT);
  EXPECT_FALSE(out.acted);
  EXPECT_NEAR(pc.state().dissipated_J[0], 0.6e-3, 1e-15);
}

TEST(PassivityController, ForceLimitBoundsTheDamper) {
  auto config = Make(PassivityMode::kEnergyExchange, 1, 2.0);
  config.max_force_N = 1.5;
  PassivityController pc(config);
  // No credit; deficit 0.75 mJ, α wanted 3 → bounded at 2: u' = 0.5 N, 0.25 mJ carried.
  auto out = pc.Step(In(1.5, 0.5), kT);
  EXPECT_DOUBLE_EQ(out.force_N[0], 0.5);
  EXPECT_NEAR(pc.state().observed_J[0], -0.25e-3, 1e-15);
  // The law already pushes against the motion at the limit: any damping would exceed |u'| ≤ 1.5 N, so none.
  out = pc.Step(In(-1.5, 1.0), kT);
  EXPECT_DOUBLE_EQ(out.force_N[0], -1.5);
  EXPECT_FALSE(out.acted);
  EXPECT_NEAR(pc.state().observed_J[0], -0.25e-3, 1e-15);
  EXPECT_EQ(pc.state().saturated_steps, 2u);
  // Room again: the carried 0.25 mJ goes with α = 0.25 N·s/m.
  out = pc.Step(In(0.0, 1.0), kT);
  EXPECT_NEAR(out.force_N[0], -0.25, 1e-12);
  EXPECT_NEAR(pc.state().observed_J[0], 0.0, 1e-15);
  EXPECT_NEAR(pc.state().dissipated_J[0], 0.75e-3, 1e-15);
}

TEST(PassivityController, NonFiniteOrMissizedInputPassesThroughCounted) {
  PassivityController pc(Make(PassivityMode::kObserver));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto out = pc.Step(In(1.0, nan), kT);
  EXPECT_EQ(out.force_N[0], 1.0);
  out = pc.Step(In(nan, 1.0), kT);
  EXPECT_TRUE(std::isnan(out.force_N[0]));
  PassivityController::Input two;
  two.force_N = DofVector::Ones(2);
  two.velocity_m_per_s = DofVector::Ones(2);
  out = pc.Step(two, kT);
  EXPECT_EQ(out.force_N.size(), 2);
  (void)pc.Step(In(1.0, 1.0), 0.0);
  EXPECT_EQ(pc.state().nonfinite_inputs, 4u);
  EXPECT_EQ(pc.state().output_energy_J[0], 0.0);
}

TEST(PassivityController, RejectsBadConfig) {
  auto config = Make(PassivityMode::kObserver, 2);
  config.max_damping_Ns_per_m = DofVector::Ones(1);
  EXPECT_THROW(PassivityController{config}, Error);
  config = Make(PassivityMode::kObserver, 1, -1.0);
  EXPECT_THROW(PassivityController{config}, Error);
  config = Make(PassivityMode::kObserver, 1, std::numeric_limits<double>::infinity());
  EXPECT_THROW(PassivityController{config}, Error);
  config = Make(PassivityMode::kObserver, kMaxDof);
  config.dof = kMaxDof + 1;
  EXPECT_THROW(PassivityController{config}, Error);
  config = Make(PassivityMode::kObserver);
  config.max_force_N = -1.0;
  EXPECT_THROW(PassivityController{config}, Error);
}

TEST(PassivityController, StepDoesNotAllocate) {
  PassivityController pc(Make(PassivityMode::kEnergyExchange, kMaxDof, 50.0));
  PassivityController::Input in;
  in.force_N = DofVector::Constant(kMaxDof, 2.0);
  in.velocity_m_per_s = DofVector::Constant(kMaxDof, 0.1);
  in.peer_input_energy_J = DofVector::Zero(kMaxDof);
  in.peer_energy_valid = true;
  test::AllocationCounter counter;
  for (int k = 0; k < 100; ++k) {
    in.peer_input_energy_J.setConstant(1e-5 * k);
    (void)pc.Step(in, kT);
  }
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_GT(pc.state().acting_steps, 0u);
}

}  // namespace
}  // namespace teleop::control
