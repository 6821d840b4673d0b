// PassivityController: the observer's energies on known power sequences, the controller dissipating exactly the
// deficit and never adding energy, its bounds, the energy-exchange credit, bad input, no allocation.

#include "teleop/control/passivity_controller.hpp"

#include <gtest/gtest.h>

#include <algorithm>
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

// With a constant velocity the interval's work u(n)·v·T is known exactly at step n+1 (backward difference), so the
// sequences below are exact; the observer settles the work of the force held over [n-1, n] at step n.

TEST(PassivityController, ObserverAccumulatesPortEnergyInAndOut) {
  PassivityController pc(Make(PassivityMode::kOff));
  // Absorb 2 N against 0.5 m/s for 10 steps (1 mJ each), then deliver 1 N at 0.5 m/s for 4 steps (0.5 mJ each).
  for (int k = 0; k < 10; ++k) (void)pc.Step(In(-2.0, 0.5), kT);
  for (int k = 0; k < 4; ++k) (void)pc.Step(In(1.0, 0.5), kT);
  (void)pc.Step(In(0.0, 0.5), kT);  // settles the last interval
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
  (void)pc.Step(In(0.0, 0.2), kT);
  EXPECT_NEAR(pc.state().observed_J[0], -5 * 0.6e-3, 1e-15);
  EXPECT_NEAR(pc.state().min_observed_J, -3e-3, 1e-15);
}

// A known active sequence: the port first absorbs 5 mJ, then the law tries to deliver 0.6 W for 20 ms (12 mJ).
// The controller lets the first 5 mJ through and dissipates exactly the 7 mJ beyond, so the port's net delivered
// energy Σ u'·v·T never exceeds what it absorbed.
TEST(PassivityController, ObserverDissipatesExactlyTheActiveEnergy) {
  PassivityController pc(Make(PassivityMode::kObserver));
  double net_delivered_J = 0.0;
  for (int k = 0; k < 5; ++k) {
    const auto out = pc.Step(In(-5.0, 0.2), kT);  // absorbs 1 mJ per step
    EXPECT_FALSE(out.acted);
    net_delivered_J += out.force_N[0] * 0.2 * kT;
  }
  for (int k = 0; k < 20; ++k) {
    const auto out = pc.Step(In(3.0, 0.2), kT);
    net_delivered_J += out.force_N[0] * 0.2 * kT;
    EXPECT_LE(net_delivered_J, 1e-15) << "step " << k;
    EXPECT_GE(out.damping_Ns_per_m[0], 0.0);
    EXPECT_LE(out.force_N[0], 3.0);
  }
  (void)pc.Step(In(0.0, 0.2), kT);  // settles the last interval
  EXPECT_NEAR(pc.state().dissipated_J[0], 12e-3 - 5e-3, 1e-14);
  EXPECT_NEAR(net_delivered_J, 0.0, 1e-14);
  EXPECT_NEAR(pc.state().observed_J[0], 0.0, 1e-15);
  EXPECT_GE(pc.state().observed_J[0], -1e-15);
  // The first 8 delivering steps (8 · 0.6 mJ = 4.8 mJ) fit in the 5 mJ; the controller acts from the 9th on.
  EXPECT_EQ(pc.state().acting_steps, 12u);
}

// The delay re-check switches an observe-only port on at run time (link.delay_recheck.on_unstable: passivity):
// the 3 mJ generated before the switch are not paid back at once (no jolt), but from the switch on the port delivers
// nothing beyond what it absorbs after it; the cumulative energies and the record of the deficit stay.
TEST(PassivityController, SwitchingOnAtRunTimeMakesThePortPassiveFromTheSwitchOn) {
  PassivityController pc(Make(PassivityMode::kOff));
  for (int k = 0; k < 5; ++k) (void)pc.Step(In(3.0, 0.2), kT);  // 0.6 mJ generated per step, unchanged
  pc.SwitchMode(PassivityMode::kObserver);
  EXPECT_EQ(pc.config().mode, PassivityMode::kObserver);
  // The first step after the switch settles the last off interval (0.6 mJ more), then predicts 0.6 mJ more: the
  // damper takes out the prediction only, not the 3 mJ before.
  double net_delivered_J = 0.0;
  for (int k = 0; k < 10; ++k) {
    const auto out = pc.Step(In(3.0, 0.2), kT);
    EXPECT_TRUE(out.acted) << "step " << k;
    EXPECT_GE(out.force_N[0], -1e-12) << "a damper sized for the old deficit would reverse the force";
    if (k > 0) net_delivered_J += out.force_N[0] * 0.2 * kT;
  }
  EXPECT_LE(net_delivered_J, 1e-14);
  // 4 intervals settled before the switch, 10 after: the law's delivery, before the damper.
  EXPECT_NEAR(pc.state().output_energy_J[0], 14 * 0.6e-3, 1e-12) << "cumulative energies kept across the switch";
  EXPECT_LE(pc.state().min_observed_J, -3e-3 + 1e-15) << "the deficit before the switch stays on record";
  // And off again: the command passes unchanged.
  pc.SwitchMode(PassivityMode::kOff);
  EXPECT_EQ(pc.Step(In(3.0, 0.2), kT).force_N[0], 3.0);
}

TEST(PassivityController, SeededRandomSequencesNeverAddEnergy) {
  const int trials = 200;  // raise to search harder
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> force(-5.0, 5.0);
  std::uniform_real_distribution<double> velocity(-0.3, 0.3);
  std::uniform_real_distribution<double> supply(0.0, 0.1e-3);
  for (const PassivityMode mode : {PassivityMode::kObserver, PassivityMode::kEnergyExchange}) {
    for (int trial = 0; trial < trials; ++trial) {
      PassivityController pc(Make(mode, 1, 1e9));
      const double v = velocity(rng);  // constant: the interval's work is what the controller predicted
      double peer_in = 0.0;
      double net_in_J = 0.0;  // absorbed by network + controller from the device
      double law_out_J = 0.0;
      for (int k = 0; k < 50; ++k) {
        auto in = In(force(rng), v);
        peer_in += supply(rng);
        in.peer_input_energy_J[0] = peer_in;
        in.peer_energy_valid = true;
        const auto out = pc.Step(in, kT);
        const double u = in.force_N[0];
        // Never adds energy: the damper's force opposes the velocity, the delivered power only ever goes down.
        ASSERT_GE(out.damping_Ns_per_m[0], 0.0);
        ASSERT_LE(out.force_N[0] * v, u * v + 1e-15);
        net_in_J -= out.force_N[0] * v * kT;
        law_out_J += std::max(0.0, out.force_N[0] * v * kT);
        if (mode == PassivityMode::kObserver) {
          ASSERT_GE(net_in_J, -1e-12) << "trial " << trial << " step " << k;
        } else {
          // What the port delivered in the intervals it had credit for never exceeds what the peer supplied.
          ASSERT_LE(law_out_J, peer_in + 1e-12) << "trial " << trial << " step " << k;
        }
      }
    }
  }
}

TEST(PassivityController, EnergyExchangeOutputsOnlyWhatThePeerSupplied) {
  PassivityController pc(Make(PassivityMode::kEnergyExchange));
  // The port itself absorbs 5 mJ: in energy_exchange that is sent to the peer, not credited locally.
  for (int k = 0; k < 5; ++k) (void)pc.Step(In(-5.0, 0.2), kT);
  // No peer energy yet: a delivering command is damped to zero net output.
  auto out = pc.Step(In(3.0, 0.2), kT);
  EXPECT_NEAR(pc.state().input_energy_J[0], 5e-3, 1e-15);
  EXPECT_EQ(pc.state().observed_J[0], 0.0);
  EXPECT_NEAR(out.force_N[0], 0.0, 1e-12);
  // The peer reports 1.2 mJ absorbed: two steps of 0.6 mJ pass untouched, the third is damped.
  auto in = In(3.0, 0.2);
  in.peer_energy_valid = true;
  in.peer_input_energy_J[0] = 1.2e-3;
  out = pc.Step(in, kT);
  EXPECT_NEAR(out.force_N[0], 3.0, 1e-9);
  out = pc.Step(in, kT);  // the same cumulative value again: no new credit
  EXPECT_NEAR(out.force_N[0], 3.0, 1e-9);
  out = pc.Step(in, kT);
  EXPECT_NEAR(out.force_N[0], 0.0, 1e-9);
  // A restarted peer (its E_in back near 0) gives no credit; its next increase does.
  in.peer_input_energy_J[0] = 0.1e-3;
  out = pc.Step(in, kT);
  EXPECT_NEAR(out.force_N[0], 0.0, 1e-9);
  in.peer_input_energy_J[0] = 0.7e-3;
  out = pc.Step(in, kT);
  EXPECT_NEAR(out.force_N[0], 3.0, 1e-9);
  // Three damped steps of 0.6 mJ each: no credit yet, credit used up, restarted peer.
  EXPECT_NEAR(pc.state().dissipated_J[0], 1.8e-3, 1e-12);
}

TEST(PassivityController, DampingBoundCarriesTheDeficitForward) {
  // α ≤ 5 N·s/m: with v = 0.2 m/s the damper takes at most 5·0.04·1e-3 = 0.2 mJ per step.
  PassivityController pc(Make(PassivityMode::kObserver, 1, 5.0));
  auto out = pc.Step(In(3.0, 0.2), kT);  // predicted deficit 0.6 mJ, 0.2 mJ of it dissipated
  EXPECT_DOUBLE_EQ(out.damping_Ns_per_m[0], 5.0);
  EXPECT_DOUBLE_EQ(out.force_N[0], 2.0);
  EXPECT_EQ(pc.state().saturated_steps, 1u);
  // The law now asks for nothing: the controller keeps dissipating the carried deficit (0.2 mJ a step).
  out = pc.Step(In(0.0, 0.2), kT);
  EXPECT_NEAR(pc.state().observed_J[0], -0.4e-3, 1e-15);
  EXPECT_DOUBLE_EQ(out.force_N[0], -1.0);
  out = pc.Step(In(0.0, 0.2), kT);
  EXPECT_DOUBLE_EQ(out.force_N[0], -1.0);
  out = pc.Step(In(0.0, 0.2), kT);
  EXPECT_NEAR(pc.state().observed_J[0], 0.0, 1e-15);
  EXPECT_FALSE(out.acted);
  EXPECT_NEAR(pc.state().dissipated_J[0], 0.6e-3, 1e-15);
}

TEST(PassivityController, ForceLimitBoundsTheDamper) {
  auto config = Make(PassivityMode::kEnergyExchange, 1, 2.0);
  config.max_force_N = 1.5;
  PassivityController pc(config);
  // No credit. 1.5 N at 0.5 m/s would deliver 0.75 mJ: α = 3 wanted, bounded at 2 → u' = 0.5 N, 0.25 mJ carried.
  auto out = pc.Step(In(1.5, 0.5), kT);
  EXPECT_DOUBLE_EQ(out.damping_Ns_per_m[0], 2.0);
  EXPECT_DOUBLE_EQ(out.force_N[0], 0.5);
  // The law pushes against the motion at the limit: the carried deficit wants α = 1 → u' = -2 N, beyond the
  // 1.5 N limit: clamped, α' = 0, the deficit stays.
  out = pc.Step(In(-1.5, 0.5), kT);
  EXPECT_NEAR(pc.state().observed_J[0], -0.25e-3, 1e-15);
  EXPECT_DOUBLE_EQ(out.force_N[0], -1.5);
  EXPECT_FALSE(out.acted);
  // The velocity reverses under the held -1.5 N (0.75 mJ delivered, no credit): α bounded at 2 → u' = -0.5 N.
  out = pc.Step(In(-1.5, -0.5), kT);
  EXPECT_DOUBLE_EQ(out.damping_Ns_per_m[0], 2.0);
  EXPECT_DOUBLE_EQ(out.force_N[0], -0.5);
  // The law swings to +1.5 N: any damping against -0.5 m/s would exceed the limit: none.
  out = pc.Step(In(1.5, -0.5), kT);
  EXPECT_DOUBLE_EQ(out.force_N[0], 1.5);
  EXPECT_FALSE(out.acted);
  EXPECT_EQ(pc.state().saturated_steps, 4u);
  EXPECT_LT(pc.state().observed_J[0], 0.0);  // the deficit the bounds left is still there, carried
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
