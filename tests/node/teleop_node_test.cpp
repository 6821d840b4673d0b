// TeleopNode, master and slave, each with a MockDevice, joined by an emulated link pair and stepped in lock-step
// in one thread (TeleopNode::Step): the cycle's order, the Command it writes, capability refusals at start-up,
// device faults, and no allocation in the cycle.

#include "teleop/node/teleop_node.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/emulated_link.hpp"
#include "test_utilities/limit_malloc.hpp"
#include "test_utilities/mock_device.hpp"

namespace teleop::node {
namespace {

using test::MockDevice;
using ::testing::HasSubstr;
using Call = MockDevice::Call;

constexpr double kPeriod_s = 0.001;
constexpr double kKp_N_per_m = 600.0;
constexpr double kFixture_N_per_m = 2000.0;

// The watchdog runs on the wall clock; a generous timeout keeps a preempted test from seeing a lost peer.
std::string Config(const char* role, bool fixture) {
  std::string text = std::string("role: ") + role + R"(
dof: 2
rate_hz: 1000
link: {security: {mode: insecure}, bind: "127.0.0.1:47001", peer: "127.0.0.1:47002", timeout_ms: 10000}
law: {kp_N_per_m: 600, kd_Ns_per_m: 0, max_force_N: 0}
device: {backend: loopback, loopback: {mass_kg: 0.04, damping_Ns_per_m: 0.41}}
stability: {check: false}
)";
  text += "safety: {fault_record_dir: \"" + ::testing::TempDir() + "\"}\n";
  if (fixture) text += "fixture: {stiffness_N_per_m: 2000, half_space: {axis: 0, offset_m: 0.005}}\n";
  return text;
}

config::ProcessConfig Parse(const std::string& text) { return config::ParseProcessConfig(text, "node.yaml"); }

/// A master and a slave node over one emulated medium; raw pointers to their mock devices (owned by the nodes).
struct Pair {
  explicit Pair(bool slave_fixture = false) : Pair(Config("master", false), Config("slave", slave_fixture)) {}
  Pair(const std::string& master_config, const std::string& slave_config,
       const transport::EmulatedMediumConfig& medium_config = {}, int dof = 2) {
    medium = std::make_shared<transport::EmulatedMedium>(medium_config);
    auto m = std::make_unique<MockDevice>(dof);
    auto s = std::make_unique<MockDevice>(dof);
    master_device = m.get();
    slave_device = s.get();
    master =
        std::make_unique<TeleopNode>(Parse(master_config), std::move(m),
                                     std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kMaster));
    slave = std::make_unique<TeleopNode>(Parse(slave_config), std::move(s),
                                         std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kSlave));
  }
  // Both nodes on the medium's simulated clock: deterministic, watchdog and engagement included.
  void Step() {
    const std::int64_t now_ns = 1'000'000'000 + static_cast<std::int64_t>(cycle) * 1'000'000;
    master->Step(cycle, kPeriod_s, now_ns);
    slave->Step(cycle, kPeriod_s, now_ns);
    medium->Advance(kPeriod_s);
    ++cycle;
  }
  /// Steps until both sides are engaged (coupling passes through aligning), then `extra` cycles more.
  void Engage(int extra = 2) {
    for (int k = 0; k < 5000 && !(master->engagement() == EngagementState::kEngaged &&
                                  slave->engagement() == EngagementState::kEngaged);
         ++k) {
      Step();
    }
    ASSERT_EQ(master->engagement(), EngagementState::kEngaged);
    ASSERT_EQ(slave->engagement(), EngagementState::kEngaged);
    for (int k = 0; k < extra; ++k) Step();
  }
  std::shared_ptr<transport::EmulatedMedium> medium;
  MockDevice* master_device = nullptr;
  MockDevice* slave_device = nullptr;
  std::unique_ptr<TeleopNode> master;
  std::unique_ptr<TeleopNode> slave;
  std::uint64_t cycle = 0;
};

TEST(TeleopNode, LifecycleThenReadWriteUpdateEveryCycleThenDeactivate) {
  int deactivations = 0;
  {
    Pair pair;
    pair.master_device->deactivations = &deactivations;
    MockDevice& d = *pair.master_device;
    ASSERT_EQ(d.calls(), 2u);
    EXPECT_EQ(d.call(0), Call::kConfigure);
    EXPECT_EQ(d.call(1), Call::kActivate);
    d.ClearLog();
    for (int k = 0; k < 3; ++k) pair.Step();
    ASSERT_EQ(d.calls(), 9u);
    for (std::size_t k = 0; k < 3; ++k) {
      EXPECT_EQ(d.call(3 * k), Call::kRead) << "cycle " << k;
      EXPECT_EQ(d.call(3 * k + 1), Call::kWrite) << "cycle " << k;
      EXPECT_EQ(d.call(3 * k + 2), Call::kUpdate) << "cycle " << k;
    }
    EXPECT_EQ(d.last_period_s, kPeriod_s);
    EXPECT_EQ(deactivations, 0);
  }
  EXPECT_EQ(deactivations, 1) << "the node deactivates its device when it goes";
}

TEST(TeleopNode, TheSlaveIsCommandedTowardsTheMasterOverTheLink) {
  Pair pair;
  pair.master_device->position_m << 0.01, -0.002;
  pair.Engage();
  // Eq. 9 with K_d = K_v = 0 and still positions: F_s = K_p (X_m - X_s), per axis; the master gets the opposite.
  const device::Command& s = pair.slave_device->last_command;
  EXPECT_NEAR(s.force_N[0], kKp_N_per_m * 0.01, 1e-9);
  EXPECT_NEAR(s.force_N[1], kKp_N_per_m * -0.002, 1e-9);
  EXPECT_NEAR(pair.master_device->last_command.force_N[0], -kKp_N_per_m * 0.01, 1e-9);
  EXPECT_EQ(s.constraint_count, 0) << "no fixture, no constraints";
}

TEST(TeleopNode, TheCommandCarriesTheFixturesPlanesWithTheirPenetration) {
  Pair pair(/*slave_fixture=*/true);
  pair.slave_device->position_m << 0.008, 0.0;  // 3 mm into the region x > 5 mm; the master stays at 0
  pair.Engage();
  const device::Command& c = pair.slave_device->last_command;
  ASSERT_EQ(c.constraint_count, 1);
  EXPECT_EQ(c.fixture_stiffness_N_per_m, kFixture_N_per_m);
  EXPECT_EQ(c.constraints[0].normal[0], 1.0);
  EXPECT_EQ(c.constraints[0].normal[1], 0.0);
  EXPECT_DOUBLE_EQ(c.constraints[0].offset_m, 0.005);
  EXPECT_NEAR(c.constraints[0].penetration_m, 0.003, 1e-12);
  EXPECT_NEAR(c.fixture_force_N[0], -kFixture_N_per_m * 0.003, 1e-9);
  // The fixture's push plus the coupling back to the master at 0.
  EXPECT_NEAR(c.force_N[0], -kFixture_N_per_m * 0.003 - kKp_N_per_m * 0.008, 1e-9);
}

TEST(TeleopNode, ADeviceFaultHoldsTheSafeStateAndTellsThePeer) {
  Pair pair;
  pair.master_device->position_m << 0.01, 0.0;
  pair.Engage();
  ASSERT_GT(pair.slave_device->last_command.force_N[0], 1.0);
  pair.master_device->faults = device::kFaultCommunication;
  const std::uint64_t writes = pair.master_device->writes;
  pair.master_device->ClearLog();
  for (int k = 0; k < 5; ++k) pair.Step();
  EXPECT_EQ(pair.master_device->writes, writes) << "a faulted device is never commanded";
  EXPECT_EQ(pair.master_device->safe_calls, 5u);
  EXPECT_EQ(pair.master_device->call(0), Call::kRead);
  EXPECT_EQ(pair.master_device->call(1), Call::kSetSafe);
  EXPECT_EQ(pair.master_device->call(2), Call::kUpdate);
  // The slave sees the fault flag and decouples into its reaction (hold where it is: still, so zero force).
  EXPECT_EQ(pair.slave->engagement(), EngagementState::kHandshaking);
  EXPECT_EQ(pair.slave_device->last_command.force_N[0], 0.0);
  pair.master_device->faults = device::kFaultNone;
  for (int k = 0; k < 5; ++k) pair.Step();
  EXPECT_EQ(pair.master_device->writes, writes + 5) << "commanded again once the fault clears";
  EXPECT_EQ(pair.master->engagement(), EngagementState::kAligning) << "re-engages only through aligning";
  pair.Engage();
  EXPECT_NEAR(pair.slave_device->last_command.force_N[0], kKp_N_per_m * 0.01, 1e-9);
}

TEST(TeleopNode, RefusesActiveGainsOnADeviceThatCannotPushNamingTheKey) {
  auto device = std::make_unique<MockDevice>(2, device::Rendering::kDissipativeOnly);
  MockDevice* d = device.get();
  int deactivations = 0;
  d->deactivations = &deactivations;
  auto medium = std::make_shared<transport::EmulatedMedium>(transport::EmulatedMediumConfig{});
  try {
    TeleopNode node(Parse(Config("master", false)), std::move(device),
                    std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kMaster));
    FAIL() << "a brake-only device accepted law.kp_N_per_m = 600";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("node.yaml"));
    EXPECT_THAT(e.what(), HasSubstr("key 'law.kp_N_per_m'"));
    EXPECT_THAT(e.what(), HasSubstr("mock"));
  }
  EXPECT_EQ(deactivations, 0) << "refused before activation";
}

TEST(TeleopNode, RefusesACobotWithDampingAndAnUnboundedForceOnALimitedMotor) {
  auto medium = std::make_shared<transport::EmulatedMedium>(transport::EmulatedMediumConfig{});
  const auto refuse = [&](std::unique_ptr<MockDevice> device, const std::string& text, const std::string& key) {
    try {
      TeleopNode node(Parse(text), std::move(device),
                      std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kMaster));
      ADD_FAILURE() << "accepted; expected a refusal naming " << key;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("key '" + key + "'"));
    }
  };
  std::string cobot = Config("master", false);
  cobot.replace(cobot.find("kp_N_per_m: 600"), 15, "kp_N_per_m: 0, kv_Ns_per_m: 1");
  refuse(std::make_unique<MockDevice>(2, device::Rendering::kSteeredConstraints), cobot, "law.kv_Ns_per_m");
  auto limited = std::make_unique<MockDevice>(2);
  limited->mutable_capabilities().max_force_N = DofVector::Constant(2, 4.0);
  refuse(std::move(limited), Config("master", false), "law.max_force_N");  // max_force_N: 0 = unbounded
  refuse(std::make_unique<MockDevice>(3), Config("master", false), "dof");
}

TEST(TeleopNode, TheBrakeReactionNeedsABrakeAndHoldsItWhileNotCoupled) {
  auto medium = std::make_shared<transport::EmulatedMedium>(transport::EmulatedMediumConfig{});
  std::string text = Config("slave", false);
  text.replace(text.find("safety: {"), 9, "safety: {reaction: brake, ");
  try {
    TeleopNode node(Parse(text), std::make_unique<MockDevice>(2),
                    std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kSlave));
    FAIL() << "a brake reaction was accepted on a device without a brake";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("key 'safety.reaction'"));
    EXPECT_THAT(e.what(), HasSubstr("'mock' has none"));
  }
  auto braked = std::make_unique<MockDevice>(2);
  braked->mutable_capabilities().has_brake = true;
  MockDevice* d = braked.get();
  TeleopNode node(Parse(text), std::move(braked),
                  std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kSlave));
  for (std::uint64_t k = 0; k < 3; ++k) node.Step(k, kPeriod_s, static_cast<std::int64_t>(k) * 1'000'000);
  EXPECT_EQ(node.engagement(), EngagementState::kHandshaking) << "no master";
  EXPECT_EQ(d->safe_calls, 3u) << "the brake (Device::SetSafe) every cycle while not coupled";
  EXPECT_EQ(d->writes, 0u);
}

TEST(TeleopNode, ConfigureAndActivateFailuresReachTheCaller) {
  auto medium = std::make_shared<transport::EmulatedMedium>(transport::EmulatedMediumConfig{});
  auto a = std::make_unique<MockDevice>(2);
  a->configure_error = "mock: no drive answers on node 5";
  EXPECT_THROW(TeleopNode(Parse(Config("master", false)), std::move(a),
                          std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kMaster)),
               Error);
  auto b = std::make_unique<MockDevice>(2);
  b->activate_error = "mock: drive stuck in Fault";
  try {
    TeleopNode node(Parse(Config("master", false)), std::move(b),
                    std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kMaster));
    FAIL() << "a failed activation was ignored";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("drive stuck in Fault"));
  }
}

TEST(TeleopNode, TheCycleAllocatesNothing) {
  Pair pair(/*slave_fixture=*/true);
  pair.master_device->position_m << 0.01, 0.0;
  pair.slave_device->position_m << 0.007, 0.0;
  pair.Engage();  // connected, fixture active
  test::AllocationCounter counter;
  for (int k = 0; k < 2000; ++k) {
    if (k == 500) pair.master_device->faults = device::kFaultDriver;  // fault, peer decouples
    if (k == 700) pair.master_device->faults = device::kFaultNone;
    pair.Step();
  }
  ASSERT_EQ(pair.slave->engagement(), EngagementState::kEngaged) << "re-engaged within the 1300 cycles";
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_NEAR(pair.slave_device->last_command.force_N[0], -kFixture_N_per_m * 0.002 + kKp_N_per_m * 0.003, 1e-9);
}

// The same at the most DOF a pair carries (kMaxDof, 12: the 7..12-DOF wire samples, the DOF sweep of
// docs/performance.md): the cycle's storage is fixed at kMaxDof, so more DOF never reaches the heap.
TEST(TeleopNode, TheCycleAllocatesNothingAtTwelveDof) {
  static_assert(kMaxDof == 12);
  auto twelve = [](std::string text) { return text.replace(text.find("dof: 2"), 6, "dof: 12"); };
  Pair pair(twelve(Config("master", false)), twelve(Config("slave", true)), {}, kMaxDof);
  pair.master_device->position_m = DofVector::Constant(kMaxDof, 0.001);
  pair.master_device->position_m[0] = 0.01;
  pair.slave_device->position_m = DofVector::Constant(kMaxDof, 0.001);
  pair.slave_device->position_m[0] = 0.007;
  pair.Engage();
  test::AllocationCounter counter;
  for (int k = 0; k < 2000; ++k) {
    if (k == 500) pair.master_device->faults = device::kFaultDriver;
    if (k == 700) pair.master_device->faults = device::kFaultNone;
    pair.Step();
  }
  ASSERT_EQ(pair.slave->engagement(), EngagementState::kEngaged) << "re-engaged within the 1300 cycles";
  EXPECT_EQ(counter.count(), 0u);
  ASSERT_EQ(pair.slave_device->last_command.force_N.size(), kMaxDof);
  // Axis 0 as at 2 DOF (fixture and coupling); axis 11 is coupled only (both ends at 1 mm: no force).
  EXPECT_NEAR(pair.slave_device->last_command.force_N[0], -kFixture_N_per_m * 0.002 + kKp_N_per_m * 0.003, 1e-9);
  EXPECT_NEAR(pair.slave_device->last_command.force_N[11], 0.0, 1e-9);
}

// ---- time-domain passivity (docs/stability.md) through the node: the controller sits between the law and the
// device, and in energy_exchange the energies cross the link in the energy block.

std::string PassiveConfig(const char* role, const char* mode) {
  // These tests are about the passivity controller: coupling engages at once (aligning ends in its first cycle).
  return Config(role, false) + "passivity: {mode: " + mode + ", max_damping_Ns_per_m: 1000}\n" +
         "engagement: {align_speed_m_per_s: 10, align_min_time_ms: 0, max_force_rate_N_per_s: 1000000}\n";
}

/// The slave starts 10 mm from a still master and moves toward it at 10 mm/s: its law pulls with 6 N in the
/// direction it moves (0.06 W into the slave). From cycle `master_moves_from` on, the master moves away at 10 mm/s
/// against its own 6 N pull: it absorbs 0.06 W from its device, which energy_exchange lets the slave give out.
struct DraggedSlave {
  explicit DraggedSlave(const char* mode, int master_moves_from = 1 << 30, double delay_s = 0.0) {
    transport::EmulatedMediumConfig medium;
    medium.master_to_slave.delay_s = medium.slave_to_master.delay_s = delay_s;
    pair = std::make_unique<Pair>(PassiveConfig("master", mode), PassiveConfig("slave", mode), medium);
    pair->slave_device->position_m << 0.01, 0.0;
    moves_from = master_moves_from;
  }
  void Step() {
    const int k = static_cast<int>(pair->cycle);
    pair->slave_device->position_m[0] -= 1e-5;
    if (k >= moves_from) pair->master_device->position_m[0] -= 1e-5;
    pair->Step();
  }
  std::unique_ptr<Pair> pair;
  int moves_from = 0;
};

TEST(TeleopNodePassivity, OffLeavesTheLawsCommandAlone) {
  DraggedSlave run("off");
  for (int k = 0; k < 50; ++k) run.Step();
  // Eq. 9: K_p (X_m - X_s), the slave at 10 mm - 50 · 10 µm (its sample of the cycle before is what the master used).
  EXPECT_NEAR(run.pair->slave_device->last_command.force_N[0], -kKp_N_per_m * (0.01 - 50e-5), 1e-9);
}

TEST(TeleopNodePassivity, EnergyExchangeGivesTheSlaveOnlyWhatTheMasterSupplied) {
  DraggedSlave run("energy_exchange", /*master_moves_from=*/100);
  for (int k = 0; k < 100; ++k) run.Step();
  // The master has put nothing in: the slave's controller damps its pull to (nearly) zero power.
  const double still = run.pair->slave_device->last_command.force_N[0];
  EXPECT_NEAR(still, 0.0, 1e-6) << "law command " << -kKp_N_per_m * 0.009;
  // The master now absorbs 0.06 W: the energy block carries it over, and the slave pulls with the law's force.
  for (int k = 0; k < 20; ++k) run.Step();
  const double released = run.pair->slave_device->last_command.force_N[0];
  EXPECT_NEAR(released, -kKp_N_per_m * (0.01 - 120e-5 + 20e-5), 0.05) << "the law's own command";
  // On the master, absorbing, the controller never acts; its command is the law's.
  EXPECT_NEAR(run.pair->master_device->last_command.force_N[0], kKp_N_per_m * (0.01 - 120e-5 + 20e-5), 0.05);
}

TEST(TeleopNodePassivity, EnergyExchangeOverADelayedLinkWaitsForTheEnergyToArrive) {
  // 20 ms one way: the slave's credit for the master's motion from cycle 100 arrives from cycle ~121 on.
  DraggedSlave run("energy_exchange", /*master_moves_from=*/100, /*delay_s=*/0.020);
  for (int k = 0; k < 115; ++k) run.Step();
  EXPECT_NEAR(run.pair->slave_device->last_command.force_N[0], 0.0, 1e-6);
  for (int k = 0; k < 20; ++k) run.Step();
  EXPECT_LT(run.pair->slave_device->last_command.force_N[0], -1.0);
}

TEST(TeleopNodePassivity, ObserverDampsTheDraggedSlaveWithoutAnyPeerEnergy) {
  DraggedSlave run("observer", /*master_moves_from=*/0);
  for (int k = 0; k < 100; ++k) run.Step();
  // Local observer only: the slave may give back what it absorbed (nothing), whatever the master does.
  EXPECT_NEAR(run.pair->slave_device->last_command.force_N[0], 0.0, 1e-6);
}

TEST(TeleopNodePassivity, TheCycleAllocatesNothingWithEnergyExchange) {
  DraggedSlave run("energy_exchange", /*master_moves_from=*/50, /*delay_s=*/0.005);
  for (int k = 0; k < 10; ++k) run.Step();
  test::AllocationCounter counter;
  for (int k = 0; k < 500; ++k) run.Step();
  EXPECT_EQ(counter.count(), 0u);
}

}  // namespace
}  // namespace teleop::node
