// The coupling's stages, each on its own (common/src/node/coupling/): inputs → outputs, no node, no link.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "node/command_queue.hpp"
#include "node/coupling/clutch.hpp"
#include "node/coupling/law_input.hpp"
#include "node/coupling/passivity_port.hpp"
#include "node/coupling/setpoints.hpp"
#include "node/coupling/shaper.hpp"

namespace teleop::node {
namespace {

constexpr double kT = 0.001;

Clutch::Input ClutchIn(bool device, bool command, bool peer, Outage blocker = Outage::kNone,
                       bool index_pending = false) {
  Clutch::Input in;
  in.device_pressed = device;
  in.command_pressed = command;
  in.peer_pressed = peer;
  in.blocker = blocker;
  in.index_pending = index_pending;
  return in;
}

TEST(CouplingClutch, PressAndReleaseAreEdgesAndAMasterFlagsAPendingReindex) {
  Clutch master({/*master=*/true, /*can_push=*/false});
  Clutch::Output o = master.Step(ClutchIn(false, false, false));
  EXPECT_EQ(o.sources, 0);
  EXPECT_FALSE(o.pressed || o.released || o.flag || o.clutch_path);
  EXPECT_EQ(o.blocker, Outage::kNone);
  o = master.Step(ClutchIn(true, false, false));
  EXPECT_EQ(o.sources, kClutchDevice);
  EXPECT_TRUE(o.pressed);
  EXPECT_EQ(o.blocker, Outage::kClutch);
  EXPECT_TRUE(o.clutch_path);  // a master's clutch always applies its own command
  EXPECT_TRUE(o.flag);
  o = master.Step(ClutchIn(true, true, false));  // a second source: no second press
  EXPECT_EQ(o.sources, kClutchDevice | kClutchCommand);
  EXPECT_FALSE(o.pressed);
  EXPECT_EQ(master.state().presses, 1u);
  o = master.Step(ClutchIn(false, false, false, Outage::kNone, /*index_pending=*/true));
  EXPECT_TRUE(o.released);
  EXPECT_EQ(o.blocker, Outage::kNone);
  EXPECT_TRUE(o.flag);  // released, but the slave holds until the master has re-indexed
  o = master.Step(ClutchIn(false, false, false));
  EXPECT_FALSE(o.released || o.flag);
}

TEST(CouplingClutch, AnotherBlockerComesFirstAndOnlyAPushingSlaveHolds) {
  Clutch slave({false, /*can_push=*/true});
  Clutch::Output o = slave.Step(ClutchIn(true, false, false, Outage::kPeerLost));
  EXPECT_EQ(o.blocker, Outage::kPeerLost);  // the reaction, not the clutch's hold
  EXPECT_FALSE(o.clutch_path);
  EXPECT_TRUE(o.flag);
  o = slave.Step(ClutchIn(false, false, true, Outage::kNone, /*index_pending=*/true));
  EXPECT_EQ(o.sources, kClutchPeer);
  EXPECT_EQ(o.blocker, Outage::kClutch);
  EXPECT_TRUE(o.clutch_path);
  EXPECT_FALSE(o.flag);  // a slave's flag carries only its own clutch
  Clutch passive({false, /*can_push=*/false});
  o = passive.Step(ClutchIn(false, true, false));
  EXPECT_EQ(o.blocker, Outage::kClutch);
  EXPECT_FALSE(o.clutch_path);  // a slave that cannot push reacts instead
}

control::ForbiddenRegionFixture::Config Fixture2(double stiffness_N_per_m) {
  control::ForbiddenRegionFixture::Config f;
  f.dof = 2;
  f.stiffness_N_per_m = stiffness_N_per_m;
  f.plane_count = 1;
  f.planes[0].normal = DofVector::Unit(2, 0);
  f.planes[0].offset_m = 0.0;
  return f;
}

TEST(CouplingSetpoints, AStiffnessRampIsLinearEndsExactlyAndALaterOneReplacesIt) {
  Setpoints stage({2});
  const control::ThreeChannelLaw::Config law = control::ThreeChannelLaw::ZeroGains(Role::kMaster, 2);
  control::ForbiddenRegionFixture::Config fixture = Fixture2(1000.0);
  Changes ramp;
  ramp.has_stiffness = true;
  ramp.stiffness = {2000.0, 4 * kT};
  const double expected[] = {1250.0, 1500.0, 1750.0, 2000.0};
  for (int n = 0; n < 4; ++n) {
    const Setpoints::Output out = stage.Step(n == 0 ? ramp : Changes{}, law, fixture, kT);
    ASSERT_TRUE(out.set_stiffness);
    EXPECT_NEAR(out.stiffness_N_per_m, expected[n], 1e-9) << n;
    fixture.stiffness_N_per_m = out.stiffness_N_per_m;
  }
  EXPECT_EQ(fixture.stiffness_N_per_m, 2000.0);
  EXPECT_FALSE(stage.Step(Changes{}, law, fixture, kT).set_stiffness);
  Changes first;
  first.has_stiffness = true;
  first.stiffness = {0.0, 10 * kT};
  fixture.stiffness_N_per_m = stage.Step(first, law, fixture, kT).stiffness_N_per_m;  // 1800
  Changes second;
  second.has_stiffness = true;
  second.stiffness = {1000.0, 2 * kT};
  EXPECT_NEAR(stage.Step(second, law, fixture, kT).stiffness_N_per_m, 1400.0, 1e-9);  // from 1800, halfway
}

TEST(CouplingSetpoints, AGainRampEndsExactlyOnTheTarget) {
  Setpoints stage({2});
  control::ThreeChannelLaw::Config law = control::ThreeChannelLaw::ZeroGains(Role::kMaster, 2);
  law.kp_N_per_m.setConstant(100.0);
  Changes change;
  change.has_gains = true;
  change.gains = {DofVector::Constant(2, 300.0), DofVector::Constant(2, 2.0), DofVector::Zero(2),
                  DofVector::Constant(2, 0.5), 3 * kT};
  change.gains.kp_N_per_m[1] = 400.0;
  Setpoints::Output out = stage.Step(change, law, Fixture2(0.0), kT);
  ASSERT_TRUE(out.set_gains);
  EXPECT_NEAR(out.gains[0][0], 100.0 + 200.0 / 3.0, 1e-9);
  EXPECT_NEAR(out.gains[0][1], 200.0, 1e-9);
  EXPECT_NEAR(out.gains[3][0], 0.5 / 3.0, 1e-12);
  out = stage.Step(Changes{}, law, Fixture2(0.0), kT);
  out = stage.Step(Changes{}, law, Fixture2(0.0), kT);
  EXPECT_EQ(out.gains[0][1], 400.0);  // exactly, not 100 + 3 · (300/3)
  EXPECT_EQ(out.gains[1][0], 2.0);
  EXPECT_FALSE(stage.state().gains.active);
  EXPECT_FALSE(stage.Step(Changes{}, law, Fixture2(0.0), kT).set_gains);
}

TEST(CouplingSetpoints, APlaneSlewsAtItsRatesAndAMoveOfAMissingPlaneIsIgnored) {
  Setpoints stage({2});
  const control::ThreeChannelLaw::Config law = control::ThreeChannelLaw::ZeroGains(Role::kMaster, 2);
  control::ForbiddenRegionFixture::Config fixture = Fixture2(1000.0);
  Changes bad;
  bad.has_plane = true;
  bad.plane = {1, DofVector::Unit(2, 1), 0.01, 1.0, 100.0};  // plane 1 is not configured
  EXPECT_FALSE(stage.Step(bad, law, fixture, kT).set_plane);
  Changes move = bad;
  move.plane.index = 0;  // to normal (0, 1), offset 10 mm at 1 m/s and 100 rad/s: 1 mm and 0.1 rad per cycle
  int cycles = 0;
  for (bool first = true; first || stage.state().slew.active; first = false) {
    const control::FixturePlane before = fixture.planes[0];
    const Setpoints::Output out = stage.Step(first ? move : Changes{}, law, fixture, kT);
    ASSERT_TRUE(out.set_plane);
    EXPECT_LE(std::abs(out.offset_m - before.offset_m), 1e-3 + 1e-12);
    EXPECT_LE(std::acos(std::clamp(out.normal.dot(before.normal), -1.0, 1.0)), 0.1 + 1e-9);
    EXPECT_NEAR(out.normal.norm(), 1.0, 1e-12);
    fixture.planes[0].normal = out.normal;
    fixture.planes[0].offset_m = out.offset_m;
    ASSERT_LT(++cycles, 100);
  }
  EXPECT_EQ(cycles, 16);  // the normal's quarter turn: ceil((π/2) / 0.1); the offset took 10
  EXPECT_EQ(fixture.planes[0].offset_m, 0.01);
  EXPECT_EQ(fixture.planes[0].normal, DofVector::Unit(2, 1));
  EXPECT_NEAR(stage.state().max_plane_offset_step_m, 1e-3, 1e-12);
  EXPECT_NEAR(stage.state().max_plane_normal_step_rad, 0.1, 1e-9);
}

struct LawInputRig {
  explicit LawInputRig(bool master, Reaction reaction = Reaction::kHold)
      : law(control::ThreeChannelLaw::ZeroGains(master ? Role::kMaster : Role::kSlave, 1)),
        reactions{SafeReaction(Safety(reaction), law), SafeReaction(Safety(Reaction::kHold), law)},
        stage({1, master, false, 1.0, EngagementConfig{}}) {
    reading.position_m = reading.velocity_m_per_s = reading.force_N = ZeroDof(1);
    peer.dof = 1;
  }
  static SafetyConfig Safety(Reaction r) {
    SafetyConfig s;
    s.reaction = r;
    return s;
  }
  LawInputStage::Output Step(bool coupling, bool aligning, bool aligning_started, bool clutched, bool clutch_path,
                             double t_s) {
    LawInputStage::Input in;
    in.reading = &reading;
    in.peer = &peer;
    in.coupling = coupling;
    in.aligning = aligning;
    in.transition.aligning_started = aligning_started;
    in.clutched = clutched;
    in.clutch_path = clutch_path;
    in.last_velocity = &zero;
    in.last_coupling_N = &zero;
    in.t_s = t_s;
    in.period_s = kT;
    return stage.Step(in, reactions);
  }
  control::ThreeChannelLaw::Config law;
  Reactions reactions;
  LawInputStage stage;
  device::Reading reading;
  proto::SampleMessage peer{};
  DofVector zero = ZeroDof(1);
};

TEST(CouplingLawInput, AMasterReindexesAtTheAligningAfterAClutch) {
  LawInputRig rig(/*master=*/true);
  rig.reading.position_m[0] = 0.02;
  rig.peer.position_m[0] = 0.05;
  LawInputStage::Output out = rig.Step(false, false, false, /*clutched=*/true, /*clutch_path=*/true, 0.0);
  EXPECT_FALSE(out.input.peer_valid);  // a clutched master runs its law without a peer
  EXPECT_TRUE(rig.stage.state().index_pending);
  out = rig.Step(true, true, /*aligning_started=*/true, false, false, kT);
  ASSERT_TRUE(out.reindexed);
  EXPECT_DOUBLE_EQ(out.shift_m[0], 0.03);
  EXPECT_DOUBLE_EQ(out.largest_offset_m, 0.03);
  EXPECT_DOUBLE_EQ(out.input.position_m[0], 0.05);       // the reading + the offset: where the slave is
  EXPECT_DOUBLE_EQ(out.input.peer_position_m[0], 0.05);  // the aligner starts there: nothing left to align
  EXPECT_FALSE(rig.stage.state().index_pending);
  EXPECT_EQ(rig.stage.state().reindexes, 1u);
  rig.reading.position_m[0] = 0.021;
  out = rig.Step(true, false, false, false, false, 2 * kT);
  EXPECT_FALSE(out.reindexed);
  EXPECT_DOUBLE_EQ(out.input.position_m[0], 0.051);
  EXPECT_TRUE(out.input.peer_valid);
}

TEST(CouplingLawInput, TheAlignerMovesTheReferenceAtItsSpeedAndTheReactionHoldsItsLatch) {
  LawInputRig rig(/*master=*/false);
  rig.peer.position_m[0] = 0.001;
  rig.peer.force_N[0] = 3.0;
  LawInputStage::Output out = rig.Step(true, true, /*aligning_started=*/true, false, false, 0.0);
  const double step_m = EngagementConfig{}.align_speed_m_per_s * kT;
  EXPECT_DOUBLE_EQ(out.input.peer_position_m[0], step_m);  // from the local position (0) toward the peer
  EXPECT_DOUBLE_EQ(out.input.peer_velocity_m_per_s[0], EngagementConfig{}.align_speed_m_per_s);
  EXPECT_EQ(out.input.peer_force_N[0], 0.0);  // K_f's force ramps in from zero
  EXPECT_DOUBLE_EQ(rig.stage.state().max_reference_step_m, step_m);
  EXPECT_DOUBLE_EQ(out.peer_local_m[0], 0.001);
  rig.reading.position_m[0] = 0.004;
  out = rig.Step(false, false, false, false, false, kT);  // coupling lost: hold latches here
  EXPECT_TRUE(out.input.peer_valid);
  EXPECT_DOUBLE_EQ(out.input.peer_position_m[0], 0.004);
  rig.reading.position_m[0] = 0.009;
  out = rig.Step(false, false, false, false, false, 2 * kT);
  EXPECT_DOUBLE_EQ(out.input.peer_position_m[0], 0.004);  // latched once, not every cycle
  EXPECT_TRUE(rig.stage.state().reaction_latched);
}

Shaper::Input ShaperIn(CouplingPath path, const control::ThreeChannelLaw::Output& law, bool aligned = false) {
  Shaper::Input in;
  in.path = path;
  in.law = &law;
  in.aligned = aligned;
  in.t_s = 0.0;
  in.period_s = kT;
  return in;
}

control::ThreeChannelLaw::Output LawOut(double command_N, double fixture_N) {
  control::ThreeChannelLaw::Output out;
  out.command_N = DofVector::Constant(1, command_N);
  out.fixture_force_N = DofVector::Constant(1, fixture_N);
  out.velocity_m_per_s = DofVector::Constant(1, 0.1);
  return out;
}

TEST(CouplingShaper, AligningLimitsTheCouplingRateButNeverTheFixture) {
  Reactions reactions{SafeReaction({}, control::ThreeChannelLaw::ZeroGains(Role::kSlave, 1)),
                      SafeReaction({}, control::ThreeChannelLaw::ZeroGains(Role::kSlave, 1))};
  Shaper shaper({1, false, 0.0, /*max_force_rate_N_per_s=*/100.0});
  const control::ThreeChannelLaw::Output law = LawOut(12.0, 2.0);  // 10 N coupling + 2 N fixture
  Shaper::Output out = shaper.Step(ShaperIn(CouplingPath::kAligning, law, /*aligned=*/true), reactions);
  EXPECT_DOUBLE_EQ(out.command.command_N[0], 0.1 + 2.0);  // 100 N/s · 1 ms of the coupling part
  EXPECT_FALSE(out.safe);
  EXPECT_FALSE(shaper.state().aligned_verdict);  // the limiter clipped: not aligned yet
  EXPECT_NEAR(shaper.state().max_aligning_force_rate, 100.0, 1e-9);
  shaper.Track(CouplingPath::kAligning, law, out, false, kT);  // holds what it let through
  EXPECT_DOUBLE_EQ(shaper.last_coupling_N()[0], 0.1);
  out = shaper.Step(ShaperIn(CouplingPath::kEngaged, law), reactions);
  EXPECT_DOUBLE_EQ(out.command.command_N[0], 12.0);
  shaper.Track(CouplingPath::kEngaged, law, out, /*engaged_now=*/true, kT);
  EXPECT_NEAR(shaper.state().max_aligning_force_rate, (10.0 - 0.1) / kT, 1e-6);  // the step at the switch
  EXPECT_DOUBLE_EQ(shaper.last_coupling_N()[0], 10.0);
}

TEST(CouplingShaper, ADeviceFaultIsTheSafeStateAndZeroForceDropsTheFixture) {
  SafetyConfig zero_force;
  zero_force.reaction = Reaction::kZeroForce;
  const control::ThreeChannelLaw::Config cfg = control::ThreeChannelLaw::ZeroGains(Role::kSlave, 1);
  Reactions reactions{SafeReaction(zero_force, cfg), SafeReaction({}, cfg)};
  Shaper shaper({1, false, 0.0, 100.0});
  const control::ThreeChannelLaw::Output law = LawOut(5.0, 3.0);
  Shaper::Output out = shaper.Step(ShaperIn(CouplingPath::kDeviceFault, law), reactions);
  EXPECT_TRUE(out.safe);
  EXPECT_EQ(out.command.command_N, ZeroDof(1));
  EXPECT_EQ(out.command.fixture_force_N, ZeroDof(1));
  out = shaper.Step(ShaperIn(CouplingPath::kReaction, law), reactions);
  EXPECT_FALSE(out.safe);
  EXPECT_EQ(out.command.command_N, ZeroDof(1));
  EXPECT_EQ(out.command.fixture_force_N, ZeroDof(1));
  EXPECT_DOUBLE_EQ(out.command.velocity_m_per_s[0], 0.1);  // the law's own values pass through
}

TEST(CouplingPassivityPort, CountsPeerSamplesWithoutEnergyAndCopiesTheEnergies) {
  PassivityPort::Config config;
  config.mode = control::PassivityMode::kEnergyExchange;
  config.dof = 1;
  config.max_damping_Ns_per_m = DofVector::Constant(1, 50.0);
  PassivityPort port(config);
  proto::SampleMessage peer{};
  peer.dof = 1;
  const DofVector force = DofVector::Constant(1, 2.0);
  const DofVector velocity = DofVector::Constant(1, 0.1);
  PassivityPort::Output out = port.Step({&force, &velocity, true, &peer}, kT);
  EXPECT_EQ(port.state().peer_without_energy, 1u);
  out = port.Step({&force, &velocity, true, nullptr}, kT);  // no sample held: nothing to count
  EXPECT_EQ(port.state().peer_without_energy, 1u);
  const control::PassivityController::State& s = port.controller().state();
  EXPECT_EQ(out.energies.input_energy_J, s.input_energy_J);
  EXPECT_EQ(out.energies.output_energy_J, s.output_energy_J);
  EXPECT_EQ(out.energies.observed_J, s.observed_J);
  EXPECT_GT(s.steps, 1u);
}

TEST(CouplingCommandQueue, ADrainFoldsTheLatestOfEachKindAndTakesAtMostEightCommands) {
  CommandQueue queue(2);
  EventLog events(64);
  for (int n = 0; n < 10; ++n) {
    PendingCommand p;
    p.kind = Event::Kind::kCommandAccepted;
    p.change = PendingCommand::Change::kStiffness;
    p.stiffness_N_per_m = 100.0 * (n + 1);
    p.ramp_s = 0.5;
    ASSERT_TRUE(queue.Post(p));
  }
  Changes changes = queue.Drain(/*command_clutch=*/true, 7, events);
  EXPECT_TRUE(changes.command_clutch);
  ASSERT_TRUE(changes.has_stiffness);
  EXPECT_EQ(changes.stiffness.target_N_per_m, 800.0);  // the eighth; two wait for the next cycle
  EXPECT_FALSE(changes.has_gains || changes.has_plane);
  PendingCommand plane;
  plane.change = PendingCommand::Change::kPlane;
  plane.normal[1] = 1.0;
  plane.offset_m = 0.02;
  ASSERT_TRUE(queue.Post(plane));
  changes = queue.Drain(false, 8, events);
  EXPECT_EQ(changes.stiffness.target_N_per_m, 1000.0);
  ASSERT_TRUE(changes.has_plane);
  EXPECT_EQ(changes.plane.normal, DofVector::Unit(2, 1));
  EXPECT_EQ(changes.plane.offset_m, 0.02);
  changes = queue.Drain(false, 9, events);
  EXPECT_FALSE(changes.has_stiffness || changes.has_plane || changes.command_clutch);
}

}  // namespace
}  // namespace teleop::node
