// The CiA 402 client against the simulated drive on the in-process emulated bus (manual clock): bring-up to
// Operation Enabled, the PDO mapping written and read back, cyclic synchronous torque with SI readings checked
// against the joint's closed-form response, and every fault path: SDO retries and aborts, a drive that never
// boots, heartbeat loss, a drive that stops answering, a drive fault with EMCY and fault reset, a drive that
// leaves Operation Enabled, quick stop, the drive's own consumer of the host's heartbeat, and no allocation in
// the cycle.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "cia402_test_rig.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/canopen_sdo.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::fieldbus {
namespace {

using cia402::DriveState;
using test::Cia402Rig;
using test::ThrownBy;

TEST(Cia402Drive, BringsTheDriveToOperationEnabledInTorqueMode) {
  Cia402Rig rig;
  rig.Build();
  rig.BringUp();
  EXPECT_TRUE(rig.drive->active());
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kOperationEnabled);
  EXPECT_EQ(rig.drive->drive_state(), DriveState::kOperationEnabled);
  EXPECT_EQ(rig.sim->nmt_state(), canopen::NmtState::kOperational);
  EXPECT_EQ(rig.sim->mode_of_operation(), cia402::kModeCyclicSynchronousTorque);
  EXPECT_TRUE(rig.drive->heartbeat_armed());
  // The drive's object dictionary holds the configured mapping (not its factory one).
  const auto& tpdo1 = rig.sim->tpdo(1);
  ASSERT_EQ(tpdo1.entry_count, 2);
  EXPECT_EQ(tpdo1.entries[0].MappingValue(), 0x6041'0010u);
  EXPECT_EQ(tpdo1.entries[1].MappingValue(), 0x6064'0020u);
  const auto& tpdo2 = rig.sim->tpdo(2);
  ASSERT_EQ(tpdo2.entry_count, 2);
  EXPECT_EQ(tpdo2.entries[0].MappingValue(), 0x606C'0020u);
  EXPECT_EQ(tpdo2.entries[1].MappingValue(), 0x6077'0010u);
  const auto& rpdo1 = rig.sim->rpdo(1);
  ASSERT_EQ(rpdo1.entry_count, 2);
  EXPECT_EQ(rpdo1.entries[1].MappingValue(), 0x6071'0010u);
  EXPECT_EQ(rig.drive->sdo_counters().timeouts, 0u);
  EXPECT_EQ(rig.drive->sdo_counters().aborts, 0u);
  EXPECT_EQ(rig.sim->counters().sdo_aborts_sent, 0u);
}

// J dω/dt = τ − bω − τc from rest: ω(t) = (τ − τc)/b (1 − e^{−t b/J}), θ(t) = (τ − τc)/b (t − J/b (1 − e^{−t b/J})).
TEST(Cia402Drive, CyclicTorqueModeReadsTheJointInSiUnits) {
  Cia402Rig rig;
  rig.Build();
  rig.BringUp();
  const SimulatedJointConfig& j = rig.sim_config.joint;
  const double torque_Nm = 0.2;
  const int cycles = 200;  // 0.2 s at 1 kHz
  Cia402Rig::CycleResult r{};
  int ok = 0;
  for (int k = 0; k < cycles; ++k) {
    r = rig.Cycle(torque_Nm);
    ASSERT_EQ(r.write, Cia402Status::kOk) << k;
    if (r.read == Cia402Status::kOk) ++ok;
    ASSERT_TRUE(r.read == Cia402Status::kOk || (k == 0 && r.read == Cia402Status::kNoNewData)) << ToString(r.read);
  }
  EXPECT_GE(ok, cycles - 1);
  EXPECT_EQ(rig.drive->counters().tpdos_rejected, 0u);
  EXPECT_EQ(rig.drive->counters().rpdos_sent, static_cast<std::uint64_t>(cycles));
  EXPECT_EQ(rig.drive->counters().syncs_sent, static_cast<std::uint64_t>(cycles));
  EXPECT_EQ(rig.sim->counters().syncs, static_cast<std::uint64_t>(cycles));
  // The reading is sampled at the last SYNC, sent ~0.1 ms into the last cycle: torque acted from the first SYNC
  // (one cycle after the first Write) for cycles - 1 periods, less the 0.5 ms lag. ±2 ms of that time is the
  // tolerance (1.2 % of ω, 10 % of θ at 0.2 s: θ grows as t² early on).
  const double t = (cycles - 1) * rig.config.cycle_period_s - j.torque_lag_s;
  const double tau = j.inertia_kg_m2 / j.viscous_Nms_per_rad;
  const double w_inf = (torque_Nm - j.coulomb_Nm) / j.viscous_Nms_per_rad;
  const double w = w_inf * (1.0 - std::exp(-t / tau));
  const double theta = w_inf * (t - tau * (1.0 - std::exp(-t / tau)));
  const double dw = w_inf / tau * std::exp(-t / tau) * 2e-3;
  EXPECT_NEAR(r.reading.velocity_rad_per_s, w, dw + 1.0 / 4096) << "expected " << w;
  EXPECT_NEAR(r.reading.position_rad, theta, w * 2e-3 + 1.0 / 4096) << "expected " << theta;
  EXPECT_NEAR(r.reading.torque_Nm, torque_Nm, 1e-3);  // 0x6077: per mille of 1 N·m
  // And the reading is the drive's own state at the SYNC, within one period of motion.
  EXPECT_NEAR(r.reading.position_rad, rig.sim->position_rad(), w * rig.config.cycle_period_s + 1.0 / 4096);
  EXPECT_EQ(r.reading.state, DriveState::kOperationEnabled);
  EXPECT_TRUE(r.reading.fresh);
  EXPECT_GT(r.reading.stamp_ns, rig.now_ns - 1'000'000);
}

TEST(Cia402Drive, ScalingAndSignFromConfig) {
  Cia402Rig rig;
  rig.config.scaling.sign = -1.0;
  rig.config.scaling.rated_torque_Nm = 2.0;
  rig.sim_config.rated_torque_mNm = 2000;
  rig.config.max_torque_Nm = 1.0;
  rig.Build();
  rig.BringUp();
  rig.sim->SetJointState(1.5, 0.0);
  Cia402Rig::CycleResult r{};
  for (int k = 0; k < 3; ++k) r = rig.Cycle(-0.4);  // −0.4 N·m in the joint frame = +0.4 N·m at the drive
  EXPECT_NEAR(rig.sim->commanded_torque_Nm(), 0.4, 1e-9);
  EXPECT_NEAR(r.reading.position_rad, -1.5, 2.0 / 4096);
  // Clamped to max_torque_Nm and counted; NaN sends 0.
  (void)rig.Cycle(-5.0);
  EXPECT_NEAR(rig.sim->commanded_torque_Nm(), 1.0, 1e-9);  // written as 500 ‰ of 2 N·m
  EXPECT_EQ(rig.drive->counters().torque_clamped, 1u);
  (void)rig.Cycle(std::nan(""));
  (void)rig.Cycle(std::nan(""));
  EXPECT_EQ(rig.sim->commanded_torque_Nm(), 0.0);
  EXPECT_EQ(rig.drive->counters().non_finite_commands, 2u);
}

TEST(Cia402Drive, SdoTimeoutsAreRetriedWithBackoff) {
  Cia402Rig rig;
  rig.Build();
  rig.sim->DropSdoResponses(2);
  rig.BringUp();
  EXPECT_EQ(rig.drive->sdo_counters().timeouts, 2u);
  EXPECT_TRUE(rig.drive->active());

  Cia402Rig dead;
  dead.Build();
  dead.sim->DropSdoResponses(1000);
  const std::string what = ThrownBy([&] { dead.drive->Configure(); });
  EXPECT_NE(what.find("SDO read of 0x1000:00 on node 1: no response within 5 ms, 4 attempts"), std::string::npos)
      << what;
  EXPECT_EQ(dead.drive->sdo_counters().timeouts, 4u);
  EXPECT_EQ(dead.drive->sdo_counters().requests, 4u);
  // Backoff 1, 2, 4 ms between 4 attempts of 5 ms: at least 27 ms from the first request.
  EXPECT_GE(dead.now_ns, 27'000'000u);
}

TEST(Cia402Drive, ADriveWithTwoPdosOfEachKindAndWithoutTheOptionalObjectsIsBroughtUp) {
  // CiA 301 asks for no number of PDOs, and 0x1006 (mandatory for a SYNC producer only) and 0x1016 are optional: a
  // drive that lacks them is switched on all the same; only a consumer asked for (drive_consumer_timeout_ms) needs
  // 0x1016.
  const auto lacking = [](Cia402Rig& rig) {
    for (const int index : {0x1402, 0x1403, 0x1802, 0x1803, 0x1006, 0x1016}) {
      rig.sim->AbortObject(static_cast<std::uint16_t>(index), canopen::sdo_abort::kNoObject);
    }
  };
  Cia402Rig rig;
  rig.Build();
  lacking(rig);
  rig.BringUp();
  EXPECT_TRUE(rig.drive->active());
  Cia402Rig::CycleResult r{};
  for (int k = 0; k < 20; ++k) r = rig.Cycle(0.1);
  EXPECT_EQ(r.read, Cia402Status::kOk);
  EXPECT_EQ(rig.drive->sdo_counters().aborts, 6u);  // one per absent object, none retried

  Cia402Rig consumer;
  consumer.config.drive_consumer_timeout_ms = 300.0;
  consumer.Build();
  lacking(consumer);
  const std::string what = ThrownBy([&] { consumer.drive->Configure(); });
  EXPECT_NE(what.find("SDO write of 0x1016:01 on node 1 aborted: 0x06020000"), std::string::npos) << what;
  EXPECT_FALSE(consumer.drive->active());
}

TEST(Cia402Drive, SdoAbortIsDecodedAndNamesTheObject) {
  Cia402Rig rig;
  rig.Build();
  rig.sim->AbortObject(0x6060, canopen::sdo_abort::kValueRange);
  const std::string what = ThrownBy([&] { rig.drive->Configure(); });
  EXPECT_NE(what.find("SDO write of 0x6060:00 on node 1 aborted: 0x06090030 Invalid value for parameter"),
            std::string::npos)
      << what;
  EXPECT_EQ(rig.drive->sdo_counters().aborts, 1u);
  EXPECT_FALSE(rig.drive->active());
  EXPECT_THROW(rig.drive->Activate(), Error);  // not configured
}

// A configure that fails after arming the drive's consumer of the host heartbeat (0x1016:01) switches it off again:
// otherwise the next session's heartbeats re-arm it and the end of that session faults the drive (EMCY 0x8130).
// Each object Configure writes after 0x1016 is refused in turn.
TEST(Cia402Drive, AFailedConfigureLeavesTheDrivesHeartbeatConsumerOff) {
  for (const std::uint16_t refused : {std::uint16_t{0x1005}, std::uint16_t{0x1600}, std::uint16_t{0x6060},
                                      std::uint16_t{0x6072}, std::uint16_t{0x6071}}) {
    SCOPED_TRACE(refused);
    Cia402Rig rig;
    rig.config.host_heartbeat_period_ms = 20.0;
    rig.config.drive_consumer_timeout_ms = 100.0;
    rig.Build();
    rig.sim->AbortObject(refused, canopen::sdo_abort::kValueRange);
    EXPECT_NE(ThrownBy([&] { rig.drive->Configure(); }).find("aborted"), std::string::npos);
    rig.sim->AbortObject(refused, 0);
    EXPECT_EQ(rig.drive->sdo().Upload(0x1016, 1, 4), 0u);
    rig.Advance(300'000'000);  // the host goes away: nothing fires
    EXPECT_EQ(rig.sim->counters().host_heartbeat_timeouts, 0u);
  }
}

TEST(Cia402Drive, ABootThatNeverComesTimesOut) {
  Cia402Rig rig;
  rig.config.boot_timeout_ms = 200.0;
  rig.Build();
  rig.sim->SetSilent(true);
  const std::string what = ThrownBy([&] { rig.drive->Configure(); });
  EXPECT_NE(what.find("no boot-up message (0x701#00) within boot_timeout_ms 200 ms"), std::string::npos) << what;
  EXPECT_GE(rig.now_ns, 200'000'000u);
  EXPECT_LT(rig.now_ns, 202'000'000u);
  EXPECT_FALSE(rig.drive->heartbeat_armed());  // the consumer never armed: only the boot timeout caught it
}

TEST(Cia402Drive, HeartbeatConsumerArmsOnTheFirstHeartbeatAndTimesOut) {
  Cia402Rig rig;
  rig.Build();
  rig.BringUp();
  ASSERT_TRUE(rig.drive->heartbeat_armed());
  // Heartbeat every 50 ms, timeout 150 ms: muted, the loss is reported within 150 ms + one heartbeat period of
  // the last heartbeat, and never before 150 ms of silence.
  for (int k = 0; k < 60; ++k) ASSERT_EQ(rig.Cycle(0.1).read, Cia402Status::kOk);
  rig.sim->SetHeartbeatMuted(true);
  int cycles = 0;
  Cia402Rig::CycleResult r{};
  do {
    r = rig.Cycle(0.1);
    ++cycles;
  } while (r.read != Cia402Status::kHeartbeatLost && cycles < 1000);
  EXPECT_EQ(r.read, Cia402Status::kHeartbeatLost);
  EXPECT_GE(cycles, 100);  // ≥ 150 ms after the last heartbeat, which was ≤ 50 ms before muting
  EXPECT_LE(cycles, 152);
  EXPECT_EQ(rig.drive->counters().heartbeat_timeouts, 1u);
  // The loss is latched and the client commands zero torque from then on.
  EXPECT_EQ(rig.Cycle(0.1).write, Cia402Status::kHeartbeatLost);
  EXPECT_EQ(rig.Cycle(0.1).read, Cia402Status::kHeartbeatLost);
  EXPECT_EQ(rig.sim->commanded_torque_Nm(), 0.0);
}

TEST(Cia402Drive, ADriveThatStopsAnsweringGoesStaleThenLost) {
  Cia402Rig rig;
  rig.Build();
  rig.BringUp();
  for (int k = 0; k < 5; ++k) (void)rig.Cycle(0.0);
  rig.sim->SetSilent(true);
  // stale_after_ms 10: the newest TPDOs were read at the end of the last good cycle, so cycles 0..9 after it (1..10
  // ms old) report no new data and cycle 10 (11 ms) is the first stale one; the heartbeat loss comes later.
  int no_new = 0;
  int stale_at = -1;
  for (int k = 0; k < 300; ++k) {
    const Cia402Status s = rig.Cycle(0.0).read;
    if (s == Cia402Status::kNoNewData) ++no_new;
    if (s == Cia402Status::kStale && stale_at < 0) stale_at = k;
    if (s == Cia402Status::kHeartbeatLost) break;
  }
  EXPECT_EQ(no_new, 10);
  EXPECT_EQ(stale_at, 10);
  EXPECT_EQ(rig.drive->counters().heartbeat_timeouts, 1u);
}

TEST(Cia402Drive, ADriveFaultSendsEmcyAndAFaultResetRecoversIt) {
  Cia402Rig rig;
  rig.Build();
  rig.BringUp();
  for (int k = 0; k < 5; ++k) (void)rig.Cycle(0.1);
  rig.sim->InjectFault(canopen::emcy::kOvercurrent);
  const Cia402Rig::CycleResult r = rig.Cycle(0.1);
  EXPECT_EQ(r.read, Cia402Status::kFault);
  EXPECT_EQ(rig.drive->last_emergency().error_code, canopen::emcy::kOvercurrent);
  EXPECT_EQ(rig.drive->last_emergency().error_register, 0x03);  // generic + current
  EXPECT_EQ(rig.drive->counters().emergencies, 1u);
  (void)rig.Cycle(0.1);
  (void)rig.Cycle(0.1);
  EXPECT_EQ(rig.drive->drive_state(), DriveState::kFault);  // from the TPDO statusword
  EXPECT_EQ(rig.drive->ReadErrorRegister(), 0x03);
  // Recovery: deactivate, activate again: the client resets the fault on a rising edge of bit 7.
  EXPECT_TRUE(rig.drive->Deactivate());
  rig.drive->Activate();
  EXPECT_EQ(rig.sim->counters().fault_resets, 1u);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kOperationEnabled);
  EXPECT_EQ(rig.drive->last_emergency().error_code, canopen::emcy::kNoError);  // the drive's "error reset" EMCY
  EXPECT_EQ(rig.drive->ReadErrorRegister(), 0x00);
  (void)rig.Cycle(0.1);
  EXPECT_EQ(rig.Cycle(0.1).read, Cia402Status::kOk);
}

TEST(Cia402Drive, ADriveThatLeavesOperationEnabledIsReported) {
  Cia402Rig rig;
  rig.Build();
  rig.BringUp();
  for (int k = 0; k < 5; ++k) (void)rig.Cycle(0.1);
  rig.sim->ForceDisable();
  const Cia402Rig::CycleResult r = rig.Cycle(0.1);
  EXPECT_EQ(r.read, Cia402Status::kNotEnabled);
  EXPECT_EQ(r.reading.state, DriveState::kSwitchOnDisabled);
  EXPECT_EQ(rig.sim->commanded_torque_Nm(), 0.0);  // a disabled drive renders nothing
}

TEST(Cia402Drive, QuickStopLeavesOperationEnabled) {
  Cia402Rig rig;
  rig.config.quick_stop_option_code = 2;  // ramp, then Switch On Disabled
  rig.Build();
  rig.BringUp();
  for (int k = 0; k < 5; ++k) (void)rig.Cycle(0.1);
  rig.drive->RequestQuickStop();
  // The drive brakes at its quick stop deceleration (0.47 rad/s at 500 rad/s², about 1 ms after the SYNC's lag),
  // then disables (transition 12): a few cycles.
  for (int k = 0; k < 4; ++k) (void)rig.Cycle(0.3);
  const Cia402Rig::CycleResult r = rig.Cycle(0.3);
  EXPECT_EQ(r.read, Cia402Status::kNotEnabled);
  EXPECT_EQ(r.reading.state, DriveState::kSwitchOnDisabled);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kSwitchOnDisabled);
}

TEST(Cia402Drive, TheDriveStopsWhenTheHostHeartbeatStops) {
  Cia402Rig rig;
  rig.config.host_heartbeat_period_ms = 20.0;
  rig.config.drive_consumer_timeout_ms = 100.0;
  rig.Build();
  rig.BringUp();
  for (int k = 0; k < 50; ++k) ASSERT_EQ(rig.Cycle(0.1).read, Cia402Status::kOk);
  EXPECT_EQ(rig.sim->counters().host_heartbeat_timeouts, 0u);
  rig.Advance(150'000'000);  // the host hangs: no Write, no heartbeat
  EXPECT_EQ(rig.sim->counters().host_heartbeat_timeouts, 1u);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kFault);
  EXPECT_EQ(rig.sim->error_code(), canopen::emcy::kHeartbeatError);
  Cia402Reading reading{};
  EXPECT_EQ(rig.drive->Read(reading), Cia402Status::kFault);
  EXPECT_EQ(rig.drive->last_emergency().error_code, canopen::emcy::kHeartbeatError);
}

TEST(Cia402Drive, WrongDriveOrConfigurationIsRefusedWithTheKey) {
  {
    Cia402Rig rig;
    rig.config.scaling.rated_torque_Nm = 2.0;  // the drive says 1 N·m
    rig.config.max_torque_Nm = 1.0;
    rig.Build();
    const std::string what = ThrownBy([&] { rig.drive->Configure(); });
    EXPECT_NE(what.find("rated torque 0x6076 is 1 N·m, the configuration says 2 N·m"), std::string::npos) << what;
  }
  Cia402Rig rig;
  transport::CanPort& port = *rig.bus.MakePort(rig.host_node).release();
  std::unique_ptr<transport::CanPort> owner(&port);
  auto refused = [&](Cia402DriveConfig c) { return ThrownBy([&] { Cia402Drive d(c, port, rig.Clock()); }); };
  Cia402DriveConfig c;
  c.node_id = 0;
  EXPECT_NE(refused(c).find("node_id must be 1..127"), std::string::npos);
  c = {};
  c.heartbeat_timeout_ms = 40.0;
  EXPECT_NE(refused(c).find("heartbeat_timeout_ms (40) must exceed drive_heartbeat_period_ms (50)"), std::string::npos);
  c = {};
  c.tpdos = {c.tpdos[0]};  // velocity not mapped
  EXPECT_NE(refused(c).find("velocity actual 0x606C"), std::string::npos) << refused(c);
  c = {};
  c.rpdos[0].entries[1].bits = 32;
  EXPECT_NE(refused(c).find("object 0x6071 is 16 bits, mapped with 32"), std::string::npos) << refused(c);
  c = {};
  c.tpdos[1].cob_id = 0x181;  // TPDO1's default
  EXPECT_NE(refused(c).find("COB-ID 0x181 used twice"), std::string::npos) << refused(c);
  c = {};
  c.max_torque_Nm = 40.0;
  EXPECT_NE(refused(c).find("max_torque_Nm"), std::string::npos);
  c = {};
  c.drive_consumer_timeout_ms = 50.0;  // slower than... the host heartbeat of 100 ms
  EXPECT_NE(refused(c).find("drive_consumer_timeout_ms"), std::string::npos);
}

TEST(Cia402Drive, ConfiguredCobIdsAreUsed) {
  Cia402Rig rig;
  rig.config.tpdos[0].cob_id = 0x1A1;
  rig.config.rpdos[0].cob_id = 0x221;
  rig.Build();
  rig.BringUp();
  for (int k = 0; k < 3; ++k) (void)rig.Cycle(0.1);
  EXPECT_EQ(rig.Cycle(0.1).read, Cia402Status::kOk);
  EXPECT_NE(rig.drive->Describe().find("RPDO 0x221, TPDO 0x1A1 0x281"), std::string::npos) << rig.drive->Describe();
  EXPECT_NEAR(rig.sim->commanded_torque_Nm(), 0.1, 1e-9);
}

TEST(Cia402Drive, ReadAndWriteDoNotAllocate) {
  Cia402Rig rig;
  rig.Build();
  rig.BringUp();
  (void)rig.Cycle(0.0);
  int ok = 0;
  ::teleop::test::AllocationCounter counter;
  for (int k = 0; k < 200; ++k) {
    const Cia402Rig::CycleResult r = rig.Cycle(0.05 * std::sin(k * 0.05));
    ok += r.read == Cia402Status::kOk && r.write == Cia402Status::kOk ? 1 : 0;
  }
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_EQ(ok, 200);
}

}  // namespace
}  // namespace teleop::fieldbus
