// The engagement state machine, the aligner and force-rate limiter, the safe-state reactions, the node's reading
// checks and the fault recorder, each on its own (teleop/node/engagement.hpp, safe_reaction.hpp,
// reading_check.hpp, fault_recorder.hpp).

#include "teleop/node/engagement.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "teleop/node/fault_recorder.hpp"
#include "teleop/node/reading_check.hpp"
#include "teleop/node/safe_reaction.hpp"

namespace teleop::node {
namespace {

constexpr double kT = 0.001;

TEST(EngagementMachine, CouplesOnlyThroughAligningAndCountsWhatHappened) {
  EngagementMachine m;
  EXPECT_EQ(m.state(), EngagementState::kDisengaged);
  auto tr = m.Update(Outage::kNoPeer, false, 0.0);
  EXPECT_EQ(m.state(), EngagementState::kHandshaking);
  EXPECT_FALSE(tr.coupling_lost);
  tr = m.Update(Outage::kNone, true, 0.001);  // `aligned` is ignored until the machine is aligning
  EXPECT_EQ(m.state(), EngagementState::kAligning);
  EXPECT_TRUE(tr.aligning_started);
  EXPECT_TRUE(m.coupling());
  tr = m.Update(Outage::kNone, false, 0.002);
  EXPECT_EQ(m.state(), EngagementState::kAligning);
  tr = m.Update(Outage::kNone, true, 0.051);
  EXPECT_EQ(m.state(), EngagementState::kEngaged);
  EXPECT_TRUE(tr.engaged);
  EXPECT_EQ(m.engagements(), 1u);
  EXPECT_NEAR(m.aligning_max_s(), 0.050, 1e-12);

  // Every kind of outage ends coupling; a peer-side one waits for the peer (handshaking), a local one disengages.
  for (const Outage o : {Outage::kPeerLost, Outage::kPeerFault, Outage::kPeerShutdown, Outage::kLinkFault,
                         Outage::kNewSession, Outage::kLatency, Outage::kDeviceFault, Outage::kNonFiniteInput}) {
    tr = m.Update(o, false, 1.0);
    EXPECT_TRUE(tr.coupling_lost) << ToString(o);
    EXPECT_EQ(m.state(), IsLocal(o) ? EngagementState::kDisengaged : EngagementState::kHandshaking) << ToString(o);
    EXPECT_EQ(m.last_outage(), o);
    tr = m.Update(o, true, 1.1);
    EXPECT_FALSE(tr.coupling_lost) << "counted once per outage";
    tr = m.Update(Outage::kNone, true, 1.2);
    EXPECT_EQ(m.state(), EngagementState::kAligning) << "never straight back to engaged after " << ToString(o);
    m.Update(Outage::kNone, true, 1.3);
    EXPECT_EQ(m.state(), EngagementState::kEngaged);
  }
  EXPECT_EQ(m.engagements(), 9u);
  EXPECT_EQ(m.couplings_lost(), 8u);
  // An outage while aligning also counts as a loss of coupling.
  m.Update(Outage::kPeerLost, false, 2.0);
  m.Update(Outage::kNone, false, 2.1);
  ASSERT_EQ(m.state(), EngagementState::kAligning);
  EXPECT_TRUE(m.Update(Outage::kLatency, false, 2.2).coupling_lost);
}

TEST(Aligner, MovesTheReferenceToThePeerAtBoundedSpeedThenFollowsIt) {
  EngagementConfig c;
  c.align_speed_m_per_s = 0.05;
  c.align_min_time_ms = 20;
  c.align_tolerance_m = 1e-4;
  Aligner a(c, 2);
  DofVector local(2), peer(2);
  local << 0.0, 0.001;
  peer << 0.010, 0.001;
  a.Start(local, 0.0);
  int cycles = 0;
  double t = 0.0;
  while (!a.aligned() && cycles < 1000) {
    t += kT;
    a.Step(peer, t, kT);
    EXPECT_LE(a.last_step_m(), 0.05 * kT + 1e-15) << "reference step bounded by speed × period";
    ++cycles;
  }
  // 10 mm at 50 mm/s: 200 cycles (the tolerance ends it 2 cycles early).
  EXPECT_GE(cycles, 198);
  EXPECT_LE(cycles, 200);
  EXPECT_NEAR(a.reference_m()[0], 0.010, 1e-4);
  EXPECT_DOUBLE_EQ(a.reference_m()[1], 0.001);
  EXPECT_DOUBLE_EQ(a.ramp(), 1.0);

  // Close already: aligned only once the minimum time (the K_f ramp) has passed.
  a.Start(peer, 5.0);
  a.Step(peer, 5.001, kT);
  EXPECT_FALSE(a.aligned());
  EXPECT_NEAR(a.ramp(), 0.05, 1e-9);
  a.Step(peer, 5.021, kT);
  EXPECT_TRUE(a.aligned());
}

TEST(ForceRateLimiter, BoundsTheRateAndReportsClipping) {
  ForceRateLimiter l(1);
  DofVector want(1);
  want << 1.0;
  l.Limit(want, 100.0, kT);  // 0.1 N per cycle
  EXPECT_NEAR(l.last_N()[0], 0.1, 1e-12);
  EXPECT_TRUE(l.clipped());
  for (int k = 0; k < 9; ++k) l.Limit(want, 100.0, kT);
  EXPECT_NEAR(l.last_N()[0], 1.0, 1e-12);
  l.Limit(want, 100.0, kT);
  EXPECT_FALSE(l.clipped());
  DofVector applied(1);
  applied << -3.0;
  l.Track(applied);
  EXPECT_EQ(l.last_N()[0], -3.0);
}

control::ThreeChannelLaw::Config Law(Role role, double kp, double kd, double max_force) {
  auto law = control::ThreeChannelLaw::ZeroGains(role, 1);
  law.kp_N_per_m[0] = kp;
  law.kd_Ns_per_m[0] = kd;
  law.max_force_N = max_force;
  return law;
}

DofVector V(double x) {
  DofVector v(1);
  v << x;
  return v;
}

/// One cycle of a reaction: input prepared, law stepped, command shaped.
struct ReactionRig {
  ReactionRig(Reaction r, const control::ThreeChannelLaw::Config& law_config, SafetyConfig safety = {})
      : law(law_config), reaction((safety.reaction = r, safety), law_config) {
    input.position_m = V(0);
    input.velocity_m_per_s = V(0);
    input.has_velocity = true;
    input.peer_position_m = V(0);
    input.peer_velocity_m_per_s = V(0);
    input.peer_force_N = V(0);
  }
  double Step(double x, double v, double t) {
    input.position_m = V(x);
    input.velocity_m_per_s = V(v);
    reaction.PrepareInput(input, kT);
    const auto out = law.Step(input, kT);
    DofVector cmd;
    safe = !reaction.Command(out, t, cmd);
    return cmd[0];
  }
  control::ThreeChannelLaw law;
  SafeReaction reaction;
  control::ThreeChannelLaw::Input input;
  bool safe = false;
};

TEST(SafeReaction, HoldPullsBackToTheLatchedPositionWithABoundedForce) {
  SafetyConfig s;
  s.hold_max_force_N = 2.0;
  ReactionRig rig(Reaction::kHold, Law(Role::kSlave, 600, 2, 10), s);
  rig.reaction.Latch(V(0.004), V(0.0), V(3.0), 0.0);
  EXPECT_NEAR(rig.Step(0.004, 0.0, 0.001), 0.0, 1e-12) << "at the latched position, still: no force";
  EXPECT_NEAR(rig.Step(0.005, 0.0, 0.002), -0.6, 1e-9) << "PD: -K_p · 1 mm (still: no K_d part)";
  EXPECT_NEAR(rig.Step(0.005, 0.1, 0.003), -0.6 - 2 * 0.1, 1e-9) << "PD: -K_p · 1 mm - K_d · 0.1 m/s";
  EXPECT_NEAR(rig.Step(0.015, 0.0, 0.004), -2.0, 1e-12) << "bounded by hold_max_force_N";
  EXPECT_FALSE(rig.safe);
}

TEST(SafeReaction, HoldKeepsTheFixtureOn) {
  auto law = Law(Role::kSlave, 600, 0, 10);
  law.fixture = control::ForbiddenRegionFixture::Eq7(2000.0);  // forbidden x > 0
  SafetyConfig s;
  s.hold_max_force_N = 1.0;
  ReactionRig rig(Reaction::kHold, law, s);
  rig.reaction.Latch(V(0.002), V(0.0), V(0.0), 0.0);
  // 2 mm inside the region at the latched position: the fixture pushes out (-4 N), the hold adds nothing.
  EXPECT_NEAR(rig.Step(0.002, 0.0, 0.001), -4.0, 1e-9);
}

TEST(SafeReaction, DecelerateStopsTheReferenceAtTheConfiguredRateThenHolds) {
  SafetyConfig s;
  s.decelerate_m_per_s2 = 1.0;
  ReactionRig rig(Reaction::kDecelerate, Law(Role::kSlave, 600, 0, 0), s);
  rig.reaction.Latch(V(0.0), V(0.1), V(0.0), 0.0);  // moving at 0.1 m/s
  for (int k = 1; k <= 200; ++k) rig.Step(0.0, 0.0, k * kT);
  // v(t) = 0.1 - t until 0.1 s: the stop is 5 mm (discretely 0.1·0.1/2 - 0.05 mm).
  EXPECT_NEAR(rig.reaction.target_m()[0], 0.005, 0.1e-3);
  const double stopped = rig.reaction.target_m()[0];
  rig.Step(0.0, 0.0, 0.3);
  EXPECT_EQ(rig.reaction.target_m()[0], stopped) << "then holds";
}

TEST(SafeReaction, FadeTakesTheCouplingForceToZeroOverTheFadeTime) {
  SafetyConfig s;
  s.fade_time_ms = 100;
  ReactionRig rig(Reaction::kFade, Law(Role::kMaster, 600, 0, 10), s);
  rig.reaction.Latch(V(0.0), V(0.0), V(4.0), 1.0);
  EXPECT_NEAR(rig.Step(0.0, 0.0, 1.0), 4.0, 1e-12);
  EXPECT_NEAR(rig.Step(0.0, 0.0, 1.05), 2.0, 1e-9);
  EXPECT_NEAR(rig.Step(0.0, 0.0, 1.1), 0.0, 1e-12);
  EXPECT_NEAR(rig.Step(0.0, 0.0, 2.0), 0.0, 1e-12);
}

TEST(SafeReaction, DampingZeroForceAndBrake) {
  SafetyConfig s;
  s.damping_Ns_per_m = 3.0;
  ReactionRig damping(Reaction::kDamping, Law(Role::kMaster, 600, 0, 10), s);
  damping.reaction.Latch(V(0.0), V(0.0), V(5.0), 0.0);
  damping.input.has_velocity = true;
  EXPECT_NEAR(damping.Step(0.0, 0.5, 0.001), -1.5, 1e-12);
  ReactionRig zero(Reaction::kZeroForce, Law(Role::kSlave, 600, 0, 10));
  zero.reaction.Latch(V(0.0), V(0.0), V(5.0), 0.0);
  EXPECT_EQ(zero.Step(0.01, 0.5, 0.001), 0.0);
  EXPECT_FALSE(zero.safe);
  ReactionRig brake(Reaction::kBrake, Law(Role::kSlave, 600, 0, 10));
  brake.reaction.Latch(V(0.0), V(0.0), V(5.0), 0.0);
  EXPECT_EQ(brake.Step(0.01, 0.5, 0.001), 0.0);
  EXPECT_TRUE(brake.safe) << "the brake is the device's safe state";
}

TEST(ReadingCheck, NonFiniteOutOfRangeAndEncoderJumps) {
  SafetyConfig s;
  s.max_abs_position_m = 0.2;
  s.max_speed_m_per_s = 1.0;
  s.encoder_slack_m = 1e-4;
  s.max_abs_force_sensor_N = 50;
  device::Capabilities caps;
  caps.measures_force = true;
  ReadingCheck check(s, caps, 1);
  device::Reading r;
  r.position_m = V(0.0);
  r.velocity_m_per_s = V(0.0);
  r.force_N = V(0.0);
  EXPECT_EQ(check.Check(r, kT), 0u);
  r.position_m = V(0.0011);  // 1 m/s × 1 ms + 0.1 mm = 1.1 mm: just inside
  EXPECT_EQ(check.Check(r, kT), 0u);
  r.position_m = V(0.0023);  // 1.2 mm in one cycle
  EXPECT_EQ(check.Check(r, kT), device::kFaultImplausible);
  EXPECT_EQ(check.encoder_jumps(), 1u);
  r.position_m = V(0.21);
  EXPECT_NE(check.Check(r, kT) & device::kFaultOutOfRange, 0u);
  r.position_m = V(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(check.Check(r, kT), device::kFaultNonFiniteSensor);
  r.position_m = V(0.0);
  EXPECT_EQ(check.Check(r, kT), 0u) << "no jump measured against a NaN";
  r.force_N = V(60.0);
  EXPECT_EQ(check.Check(r, kT), device::kFaultOutOfRange);
  r.force_N = V(std::numeric_limits<double>::infinity());
  EXPECT_EQ(check.Check(r, kT), device::kFaultNonFiniteSensor);
}

TEST(FaultRecorder, WritesTheLastNCyclesBeforeTheFaultAndListsEveryFault) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "fault_recorder_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  FaultRecorder rec(50, 1, dir.string(), "slave", 1);
  for (std::uint64_t c = 0; c < 120; ++c) {
    runtime::TelemetryRecord r{};
    r.cycle = c;
    r.dof = 1;
    r.position_m[0] = static_cast<double>(c);
    rec.Record(r);
  }
  FaultRecorder::Info info;
  info.kind = Outage::kPeerLost;
  info.cycle = 119;
  info.time_s = 0.119;
  info.reaction = Reaction::kHold;
  info.peer_sample_age_s = 0.051;
  rec.Trigger(info);
  info.kind = Outage::kDeviceFault;
  rec.Trigger(info);  // beyond max_files: listed, not written
  rec.Stop();
  const auto reports = rec.Reports();
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(rec.skipped(), 1u);
  EXPECT_EQ(reports[0].reaction, "hold");
  EXPECT_TRUE(reports[1].file.empty());
  ASSERT_FALSE(reports[0].file.empty());
  EXPECT_EQ(std::filesystem::path(reports[0].file).filename().string(), "teleop-slave-fault-1-cycle119-peer_lost.csv");
  std::ifstream in(reports[0].file);
  std::string line;
  int rows = 0;
  std::string first;
  std::string last;
  std::getline(in, line);
  EXPECT_EQ(line.rfind("cycle,time_s,dof,position_m_0", 0), 0u);
  while (std::getline(in, line)) {
    if (rows == 0) first = line;
    last = line;
    ++rows;
  }
  EXPECT_EQ(rows, 50);
  EXPECT_EQ(first.rfind("70,", 0), 0u) << first;
  EXPECT_EQ(last.rfind("119,", 0), 0u) << last;
}

}  // namespace
}  // namespace teleop::node
