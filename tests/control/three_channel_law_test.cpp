#include "teleop/control/three_channel_law.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "teleop/error.hpp"

namespace teleop::control {
namespace {

using Status = ThreeChannelLaw::StepStatus;
constexpr double kPeriod = 0.001;
constexpr double kTol = 1e-12;

DofVector One(double x) { return DofVector::Constant(1, x); }

ThreeChannelLaw::Config Gains(Role role, double kp, double kd, double kv, double kf) {
  ThreeChannelLaw::Config config = ThreeChannelLaw::ZeroGains(role, 1);
  config.kp_N_per_m[0] = kp;
  config.kd_Ns_per_m[0] = kd;
  config.kv_Ns_per_m[0] = kv;
  config.kf[0] = kf;
  return config;
}

// Local and peer state with measured velocities (so each term is checked without the estimator).
ThreeChannelLaw::Input In(double x_l, double v_l, double x_r, double v_r, double f_r) {
  ThreeChannelLaw::Input in;
  in.position_m = One(x_l);
  in.velocity_m_per_s = One(v_l);
  in.has_velocity = true;
  in.peer_position_m = One(x_r);
  in.peer_velocity_m_per_s = One(v_r);
  in.peer_force_N = One(f_r);
  in.peer_valid = true;
  return in;
}

TEST(ThreeChannelLaw, PositionTermMasterOpposesSlaveDrives) {
  // Master ahead of the slave by 6 mm: eq. 8 F_am = K_pm(X_m - X_s) = 3.6 N, the master command is -3.6 N.
  ThreeChannelLaw master(Gains(Role::kMaster, 600.0, 0.0, 0.0, 0.0));
  const auto m = master.Step(In(0.010, 0.0, 0.004, 0.0, 0.0), kPeriod);
  EXPECT_NEAR(m.command_N[0], -3.6, kTol);
  EXPECT_EQ(m.status, Status::kOk);
  // Slave 6 mm behind the master: eq. 9 F_as = K_ps(X_m - X_s) = +3.6 N drives it forward.
  ThreeChannelLaw slave(Gains(Role::kSlave, 600.0, 0.0, 0.0, 0.0));
  const auto s = slave.Step(In(0.004, 0.0, 0.010, 0.0, 0.0), kPeriod);
  EXPECT_NEAR(s.command_N[0], +3.6, kTol);
}

TEST(ThreeChannelLaw, DerivativeTerm) {
  ThreeChannelLaw master(Gains(Role::kMaster, 0.0, 2.0, 0.0, 0.0));
  EXPECT_NEAR(master.Step(In(0.0, 0.30, 0.0, 0.10, 0.0), kPeriod).command_N[0], -2.0 * (0.30 - 0.10), kTol);
  ThreeChannelLaw slave(Gains(Role::kSlave, 0.0, 2.0, 0.0, 0.0));
  // eq. 9: K_ds(Ẋ_m - Ẋ_s) with Ẋ_m = 0.30 (peer), Ẋ_s = 0.10 (local) = +0.4 N.
  EXPECT_NEAR(slave.Step(In(0.0, 0.10, 0.0, 0.30, 0.0), kPeriod).command_N[0], +0.4, kTol);
}

TEST(ThreeChannelLaw, VelocityFeedbackDampsBothSides) {
  // eq. 8: F_am = K_vm·Ẋ_m → command -K_vm·Ẋ_m; eq. 9: -K_vs·Ẋ_s. Both resist the local motion.
  ThreeChannelLaw master(Gains(Role::kMaster, 0.0, 0.0, 2.0, 0.0));
  EXPECT_NEAR(master.Step(In(0.0, 0.3, 0.0, 5.0, 0.0), kPeriod).command_N[0], -0.6, kTol);
  ThreeChannelLaw slave(Gains(Role::kSlave, 0.0, 0.0, 2.0, 0.0));
  EXPECT_NEAR(slave.Step(In(0.0, 0.3, 0.0, 5.0, 0.0), kPeriod).command_N[0], -0.6, kTol);
}

TEST(ThreeChannelLaw, ForceFeedForwardOnlyOnTheMaster) {
  // The slave pushes its environment with F_e = 2 N: eq. 8 F_am = K_fm·F_e = 1 N, the master resists the operator.
  ThreeChannelLaw master(Gains(Role::kMaster, 0.0, 0.0, 0.0, 0.5));
  EXPECT_NEAR(master.Step(In(0.0, 0.0, 0.0, 0.0, 2.0), kPeriod).command_N[0], -1.0, kTol);
  // Eq. 9 has no force term: a slave law with K_f ≠ 0 is refused with a message that says so.
  try {
    ThreeChannelLaw slave(Gains(Role::kSlave, 0.0, 0.0, 0.0, 0.5));
    FAIL() << "a slave law with kf != 0 was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("kf"), std::string::npos) << e.what();
  }
  // And the slave ignores the peer force it receives (the operator force) when kf = 0.
  ThreeChannelLaw slave(Gains(Role::kSlave, 0.0, 0.0, 0.0, 0.0));
  EXPECT_EQ(slave.Step(In(0.0, 0.0, 0.0, 0.0, 7.0), kPeriod).command_N[0], 0.0);
}

TEST(ThreeChannelLaw, AllTermsTogetherMatchEquation8) {
  ThreeChannelLaw master(Gains(Role::kMaster, 600.0, 2.0, 0.5, 0.3));
  // -600(0.011 - 0.004) - 2(1.0 - 0.1) - 0.5·1.0 - 0.3·2.0 = -4.2 - 1.8 - 0.5 - 0.6
  EXPECT_NEAR(master.Step(In(0.011, 1.0, 0.004, 0.1, 2.0), kPeriod).command_N[0], -7.1, kTol);
}

TEST(ThreeChannelLaw, PeerScaling) {
  auto config = Gains(Role::kMaster, 100.0, 1.0, 0.0, 0.5);
  config.peer_position_scale = 0.5;  // the slave works at twice the master's scale
  config.peer_force_scale = 0.25;
  ThreeChannelLaw master(config);
  // peer x 0.02 → 0.01 local, peer v 0.4 → 0.2 local, peer F 8 → 2 N local:
  // -100(0.012 - 0.01) - 1(0.3 - 0.2) - 0.5·2 = -0.2 - 0.1 - 1.0
  EXPECT_NEAR(master.Step(In(0.012, 0.3, 0.02, 0.4, 8.0), kPeriod).command_N[0], -1.3, kTol);
}

TEST(ThreeChannelLaw, FixtureIsSubtractedOnBothSides) {
  for (Role role : {Role::kMaster, Role::kSlave}) {
    auto config = Gains(role, 0.0, 0.0, 0.0, 0.0);
    config.fixture = ForbiddenRegionFixture::Eq7(1000.0);
    ThreeChannelLaw law(config);
    const auto out = law.Step(In(0.002, 0.0, 0.0, 0.0, 0.0), kPeriod);
    EXPECT_NEAR(out.command_N[0], -2.0, kTol) << ToString(role);  // -F_VF = -K·X
    EXPECT_NEAR(out.fixture_force_N[0], -2.0, kTol);
    EXPECT_NEAR(out.fixture_penetration_m, 0.002, 1e-15);
    EXPECT_EQ(law.Step(In(-0.002, 0.0, 0.0, 0.0, 0.0), kPeriod).command_N[0], 0.0);
  }
}

TEST(ThreeChannelLaw, SaturationClampsEachDofAndIsCounted) {
  auto config = ThreeChannelLaw::ZeroGains(Role::kSlave, 2);
  config.kp_N_per_m << 1000.0, 1000.0;
  config.max_force_N = 5.0;
  ThreeChannelLaw law(config);
  ThreeChannelLaw::Input in;
  in.position_m = DofVector::Zero(2);
  in.peer_position_m = DofVector(2);
  in.peer_position_m << 0.01, -0.002;  // wants +10 N and -2 N
  in.peer_velocity_m_per_s = DofVector::Zero(2);
  in.peer_force_N = DofVector::Zero(2);
  in.peer_valid = true;
  const auto out = law.Step(in, kPeriod);
  EXPECT_NEAR(out.command_N[0], 5.0, kTol);
  EXPECT_NEAR(out.command_N[1], -2.0, kTol);
  EXPECT_EQ(out.status, Status::kSaturated);
  in.peer_position_m << -0.02, 0.0;
  EXPECT_NEAR(law.Step(in, kPeriod).command_N[0], -5.0, kTol);
  EXPECT_EQ(law.state().saturated_steps, 2u);
}

// Status precedence kPeerMissing > kSaturated (header): a saturated step without a peer still says the peer is
// missing, and the saturation is still counted.
TEST(ThreeChannelLaw, SaturationDoesNotHideAMissingPeer) {
  for (Role role : {Role::kMaster, Role::kSlave}) {
    auto config = Gains(role, 600.0, 2.0, 0.0, 0.0);
    config.fixture = ForbiddenRegionFixture::Eq7(1000.0);
    config.max_force_N = 5.0;
    ThreeChannelLaw law(config);
    auto in = In(0.020, 0.0, 0.0, 0.0, 0.0);  // fixture alone wants -20 N, beyond the 5 N limit
    in.peer_valid = false;
    const auto out = law.Step(in, kPeriod);
    EXPECT_EQ(out.status, Status::kPeerMissing) << ToString(role) << ": " << ToString(out.status);
    EXPECT_NEAR(out.command_N[0], -5.0, kTol);
    EXPECT_EQ(law.state().saturated_steps, 1u);
    EXPECT_EQ(law.state().peer_missing_steps, 1u);
  }
}

// Finite inputs times finite gains can overflow to inf (or inf - inf = NaN). The law's guard turns that into the
// safe state (zero command, kNonFiniteInput), with or without a force limit: a clamp must not make an overflow
// look like an ordinary saturation, and NaN compares false with the limit so a clamp alone would pass it through.
TEST(ThreeChannelLaw, OverflowGivesTheSafeStateNotASaturatedCommand) {
  const double big = std::numeric_limits<double>::max();
  for (double max_force : {0.0, 10.0}) {
    SCOPED_TRACE("max_force_N " + std::to_string(max_force));
    // K_p·(x_l - x_r) = 1e308 · 4 m overflows to +inf: command -inf.
    auto config = Gains(Role::kMaster, 1e308, 0.0, 0.0, 0.0);
    config.max_force_N = max_force;
    ThreeChannelLaw inf_law(config);
    const auto a = inf_law.Step(In(2.0, 0.0, -2.0, 0.0, 0.0), kPeriod);
    EXPECT_EQ(a.status, Status::kNonFiniteInput) << ToString(a.status);
    EXPECT_EQ(a.command_N[0], 0.0);
    EXPECT_EQ(inf_law.state().nonfinite_inputs, 1u);
    EXPECT_EQ(inf_law.state().saturated_steps, 0u);
    // -K_p·Δx = -inf and -K_f·F_r = +inf: their sum is NaN.
    auto nan_config = Gains(Role::kMaster, big, 0.0, 0.0, big);
    nan_config.max_force_N = max_force;
    ThreeChannelLaw nan_law(nan_config);
    const auto b = nan_law.Step(In(4.0, 0.0, 0.0, 0.0, -4.0), kPeriod);
    EXPECT_EQ(b.status, Status::kNonFiniteInput) << ToString(b.status);
    EXPECT_EQ(b.command_N[0], 0.0);
    EXPECT_EQ(nan_law.state().nonfinite_inputs, 1u);
  }
}

TEST(ThreeChannelLaw, PerDofGains) {
  auto config = ThreeChannelLaw::ZeroGains(Role::kMaster, 3);
  config.kp_N_per_m << 100.0, 200.0, 300.0;
  ThreeChannelLaw law(config);
  ThreeChannelLaw::Input in;
  in.position_m = DofVector::Constant(3, 0.01);
  in.peer_position_m = DofVector::Zero(3);
  in.peer_velocity_m_per_s = DofVector::Zero(3);
  in.peer_force_N = DofVector::Zero(3);
  in.peer_valid = true;
  const auto out = law.Step(in, kPeriod);
  EXPECT_NEAR(out.command_N[0], -1.0, kTol);
  EXPECT_NEAR(out.command_N[1], -2.0, kTol);
  EXPECT_NEAR(out.command_N[2], -3.0, kTol);
}

TEST(ThreeChannelLaw, NonFiniteInputGivesZeroCommand) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  auto config = Gains(Role::kMaster, 600.0, 2.0, 1.0, 0.5);
  config.fixture = ForbiddenRegionFixture::Eq7(1000.0);
  ThreeChannelLaw law(config);
  int bad = 0;
  for (const auto& in : {In(nan, 0.0, 0.0, 0.0, 0.0), In(0.01, inf, 0.0, 0.0, 0.0), In(0.01, 0.0, nan, 0.0, 0.0),
                         In(0.01, 0.0, 0.0, -inf, 0.0), In(0.01, 0.0, 0.0, 0.0, nan)}) {
    const auto out = law.Step(in, kPeriod);
    EXPECT_EQ(out.status, Status::kNonFiniteInput);
    EXPECT_EQ(out.command_N.size(), 1);
    EXPECT_EQ(out.command_N[0], 0.0);
    ++bad;
  }
  // A bad period and a wrongly sized vector are bad input as well.
  EXPECT_EQ(law.Step(In(0.01, 0.0, 0.0, 0.0, 0.0), 0.0).status, Status::kNonFiniteInput);
  EXPECT_EQ(law.Step(In(0.01, 0.0, 0.0, 0.0, 0.0), nan).status, Status::kNonFiniteInput);
  auto wrong = In(0.01, 0.0, 0.0, 0.0, 0.0);
  wrong.peer_position_m = DofVector::Zero(2);
  EXPECT_EQ(law.Step(wrong, kPeriod).status, Status::kNonFiniteInput);
  EXPECT_EQ(law.state().nonfinite_inputs, static_cast<std::uint64_t>(bad + 3));
  // A NaN in peer data that is not valid is never looked at.
  auto stale = In(0.0, 0.0, nan, nan, nan);
  stale.peer_valid = false;
  EXPECT_EQ(law.Step(stale, kPeriod).status, Status::kPeerMissing);
}

TEST(ThreeChannelLaw, PeerMissingKeepsOnlyDampingAndFixture) {
  auto config = Gains(Role::kSlave, 600.0, 2.0, 1.5, 0.0);
  config.fixture = ForbiddenRegionFixture::Eq7(1000.0);
  ThreeChannelLaw law(config);
  auto in = In(0.003, 0.2, 0.05, 1.0, 3.0);
  in.peer_valid = false;
  const auto out = law.Step(in, kPeriod);
  EXPECT_EQ(out.status, Status::kPeerMissing);
  EXPECT_NEAR(out.command_N[0], -1.5 * 0.2 - 1000.0 * 0.003, kTol);
  EXPECT_EQ(law.state().peer_missing_steps, 1u);
}

TEST(ThreeChannelLaw, EstimatesVelocityWhenNoneIsMeasured) {
  auto config = Gains(Role::kMaster, 0.0, 0.0, 2.0, 0.0);
  ThreeChannelLaw law(config);
  auto in = In(0.0, 0.0, 0.0, 0.0, 0.0);
  in.has_velocity = false;
  EXPECT_EQ(law.Step(in, kPeriod).command_N[0], 0.0);  // first sample: v = 0
  in.position_m = One(0.001);
  const auto out = law.Step(in, kPeriod);
  EXPECT_NEAR(out.velocity_m_per_s[0], 1.0, 1e-9);  // eq. 20
  EXPECT_NEAR(out.command_N[0], -2.0, 1e-9);
  // A bad local sample resets the estimator: no velocity spike when good samples return.
  in.position_m = One(std::numeric_limits<double>::quiet_NaN());
  (void)law.Step(in, kPeriod);
  in.position_m = One(0.5);
  EXPECT_EQ(law.Step(in, kPeriod).velocity_m_per_s[0], 0.0);
}

TEST(ThreeChannelLaw, VelocityFilterIsApplied) {
  auto config = Gains(Role::kMaster, 0.0, 0.0, 1.0, 0.0);
  config.velocity_filter_hz = 200.0;
  ThreeChannelLaw law(config);
  auto in = In(0.0, 0.0, 0.0, 0.0, 0.0);
  in.has_velocity = false;
  (void)law.Step(in, kPeriod);
  in.position_m = One(0.001);  // raw 1 m/s; filtered a·1 with a = 1 - exp(-0.4π)
  EXPECT_NEAR(law.Step(in, kPeriod).velocity_m_per_s[0], 0.7153905, 1e-6);
}

TEST(ThreeChannelLaw, RejectsBadConfigWithActionableMessages) {
  auto expect_error = [](const ThreeChannelLaw::Config& config, const std::string& word) {
    try {
      ThreeChannelLaw law(config);
      ADD_FAILURE() << "accepted a config that should fail on " << word;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
  };
  auto c = Gains(Role::kMaster, -1.0, 0.0, 0.0, 0.0);
  expect_error(c, "kp_N_per_m");
  c = Gains(Role::kMaster, 0.0, std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0);
  expect_error(c, "kd_Ns_per_m");
  c = Gains(Role::kMaster, 0.0, 0.0, 0.0, 0.0);
  c.kv_Ns_per_m = DofVector::Zero(2);
  expect_error(c, "kv_Ns_per_m");
  c = Gains(Role::kMaster, 0.0, 0.0, 0.0, 0.0);
  c.peer_position_scale = 0.0;
  expect_error(c, "peer_position_scale");
  c = Gains(Role::kMaster, 0.0, 0.0, 0.0, 0.0);
  c.max_force_N = -1.0;
  expect_error(c, "max_force_N");
  c = Gains(Role::kMaster, 0.0, 0.0, 0.0, 0.0);
  c.velocity_filter_hz = -5.0;
  expect_error(c, "velocity_filter_hz");
  c = Gains(Role::kMaster, 0.0, 0.0, 0.0, 0.0);
  c.dof = kMaxDof + 1;
  expect_error(c, "dof");
  c = ThreeChannelLaw::ZeroGains(Role::kMaster, 2);
  c.fixture = ForbiddenRegionFixture::Eq7(100.0);  // 1-DOF fixture on a 2-DOF law
  expect_error(c, "fixture");
  // A negative K_f is allowed (it is a feed-forward, not a stiffness).
  EXPECT_NO_THROW(ThreeChannelLaw(Gains(Role::kMaster, 0.0, 0.0, 0.0, -0.5)));
}

}  // namespace
}  // namespace teleop::control
