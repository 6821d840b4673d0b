// CiA 402 cyclic synchronous position (8), velocity (9) and torque (10) against the simulated drive: the mode checked
// against 0x6502, the RPDO mapped per mode (golden bytes of the cycle's RPDO), the drive's position and velocity
// loops followed, quick stop by 0x605A and halt by controlword bit 8 (CiA 402 §"Quick stop option code", "Halt
// option code", statusword bit 10 and 12 of the cyclic modes).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "cia402_test_rig.hpp"
#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::fieldbus {
namespace {

using cia402::DriveState;
using test::Cia402Rig;
using test::ThrownBy;

std::string Hex(const proto::can::CanFrame& f) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%03X#", static_cast<unsigned>(f.id));
  std::string s = buf;
  for (std::size_t i = 0; i < f.len; ++i) {
    std::snprintf(buf, sizeof buf, "%02X", f.data[i]);
    s += buf;
  }
  return s;
}

/// The last RPDO1 (0x201) the monitor saw.
std::string LastRpdo(const Cia402Rig& rig) {
  std::string last;
  for (const auto& f : rig.captured) {
    if (f.id == 0x201) last = Hex(f);
  }
  return last;
}

TEST(Cia402Modes, VelocityModeMapsTheTargetVelocityAndTheDriveLoopFollowsIt) {
  Cia402Rig rig;
  rig.config.mode = Cia402Mode::kCyclicSynchronousVelocity;
  rig.capture = true;
  rig.Build();
  rig.BringUp();
  EXPECT_EQ(rig.sim->mode_of_operation(), cia402::kModeCyclicSynchronousVelocity);
  const auto& rpdo1 = rig.sim->rpdo(1);
  ASSERT_EQ(rpdo1.entry_count, 2);
  EXPECT_EQ(rpdo1.entries[0].MappingValue(), 0x6040'0010u);
  EXPECT_EQ(rpdo1.entries[1].MappingValue(), 0x60FF'0020u);
  Cia402Rig::CycleResult r{};
  for (int k = 0; k < 200; ++k) r = rig.Cycle(5.0);
  // 5 rad/s = 20480 units of 1/4096 rad/s = 0x00005000: controlword 0x000F, target LE.
  EXPECT_EQ(LastRpdo(rig), "201#0F0000500000");
  // PI velocity loop: no steady-state error; 1 unit (1/4096 rad/s) of quantisation in the reading.
  EXPECT_EQ(r.read, Cia402Status::kOk);
  EXPECT_NEAR(r.reading.velocity_rad_per_s, 5.0, 2.0 / 4096);
  EXPECT_NE(r.reading.statusword & cia402::sw::kFollowsCommand, 0);
}

TEST(Cia402Modes, VelocityIsClampedToTheConfiguredLimit) {
  Cia402Rig rig;
  rig.config.mode = Cia402Mode::kCyclicSynchronousVelocity;
  rig.config.max_velocity_rad_per_s = 2.0;
  rig.Build();
  rig.BringUp();
  Cia402Rig::CycleResult r{};
  for (int k = 0; k < 200; ++k) r = rig.Cycle(-5.0);
  EXPECT_NEAR(r.reading.velocity_rad_per_s, -2.0, 2.0 / 4096);
  EXPECT_EQ(rig.drive->counters().velocity_clamped, 200u);
  (void)rig.Cycle(std::nan(""));
  EXPECT_EQ(rig.drive->counters().non_finite_commands, 1u);
}

// The drive's loops (SimulatedLoopConfig): velocity loop kv/J = 600 rad/s, position loop kp = 100 rad/s. With the
// velocity loop that much faster, θ follows a small step (unsaturated: kv · kp · Δ < the torque limit) as
// θ0 + Δ (1 − e^{−kp (t − t0)}), t0 the SYNC that applied it. The tolerance on time is the velocity loop's own lag
// (1/600 s plus the 0.5 ms torque lag: ~2.2 ms); the slow PI zero (ki/kv = 20 rad/s) adds a tail, bounded by 3 %.
TEST(Cia402Modes, PositionModeStartsAtTheActualPositionAndFollowsAStepAsTheDriveLoopsPredict) {
  Cia402Rig rig;
  rig.config.mode = Cia402Mode::kCyclicSynchronousPosition;
  rig.sim_config.position_rad_per_count = 1.0 / 1048576;  // 2^20 counts per rad
  rig.config.scaling.position_rad_per_count = 1.0 / 1048576;
  rig.capture = true;
  rig.Build();
  rig.sim->SetJointState(1.0, 0.0);
  rig.BringUp();
  EXPECT_EQ(rig.sim->mode_of_operation(), cia402::kModeCyclicSynchronousPosition);
  EXPECT_EQ(rig.sim->rpdo(1).entries[1].MappingValue(), 0x607A'0020u);
  // Enabled on the spot: the target was written as the actual position (1 rad = 2^20 counts) before enabling.
  EXPECT_NEAR(rig.drive->position_target_rad(), 1.0, 1e-6);
  Cia402Rig::CycleResult r = rig.Cycle(1.0);
  EXPECT_EQ(LastRpdo(rig), "201#0F0000001000");  // 0x00100000
  EXPECT_NEAR(rig.sim->position_rad(), 1.0, 1e-5);
  const double kp = rig.sim_config.loops.position_kp_per_s;
  const double lag_s = 1.0 / 600.0 + 0.5e-3;
  const double step = 0.01;
  for (int k = 1; k <= 60; ++k) {
    r = rig.Cycle(1.0 + step);
    // Cycle k's target is applied at the SYNC ~0.1 ms into it; the reading was sampled at the SYNC of cycle k.
    const double t = (k - 1) * 1e-3;
    const double low = step * (1.0 - std::exp(-kp * std::max(0.0, t - lag_s))) - 0.03 * step;
    const double high = step * (1.0 - std::exp(-kp * t)) + 0.03 * step;
    EXPECT_GE(r.reading.position_rad - 1.0, low) << k;
    EXPECT_LE(r.reading.position_rad - 1.0, high) << k;
  }
  EXPECT_NEAR(r.reading.position_rad, 1.0 + step, 0.03 * step);
  EXPECT_EQ(LastRpdo(rig), "201#0F00F6281000");  // 1.01 · 2^20 = 1059061.76 → 1059062 = 0x001028F6
}

TEST(Cia402Modes, PositionTargetsMoveNoFasterThanTheLimitAndHoldOnNaN) {
  Cia402Rig rig;
  rig.config.mode = Cia402Mode::kCyclicSynchronousPosition;
  rig.config.max_velocity_rad_per_s = 2.0;  // 2 mrad per 1 ms cycle
  rig.Build();
  rig.BringUp();
  for (int k = 0; k < 10; ++k) (void)rig.Cycle(1.0);
  EXPECT_NEAR(rig.drive->position_target_rad(), 0.020, 1e-9);
  EXPECT_EQ(rig.drive->counters().position_step_clamped, 10u);
  (void)rig.Cycle(std::nan(""));
  EXPECT_NEAR(rig.drive->position_target_rad(), 0.020, 1e-9);
  EXPECT_EQ(rig.drive->counters().non_finite_commands, 1u);
}

// SYNC timing (CiA 301: a synchronous RPDO takes effect at the next SYNC). A loop that wakes late and runs its
// missed cycles back to back must not put a burst of SYNCs on the wire: a Write within half a cycle period of the
// last SYNC sends nothing (counted), so the SYNCs stay at least half a period apart, each SYNC follows its RPDO, and
// the position target moves at most max_velocity_rad_per_s · cycle_period_s per SYNC.
TEST(Cia402Modes, ALateLoopSendsNoBurstOfSyncsAndThePositionStepPerSyncStaysWithinTheLimit) {
  Cia402Rig rig;
  rig.config.mode = Cia402Mode::kCyclicSynchronousPosition;
  rig.config.max_velocity_rad_per_s = 2.0;  // 2 mrad per 1 ms cycle
  rig.Build();
  rig.BringUp();
  rig.capture = true;
  rig.captured.clear();
  const std::uint64_t period_ns = 1'000'000;
  for (int k = 0; k < 30; ++k) {
    if (k % 10 == 9) {  // a late wake-up: three periods late, then the three missed cycles back to back
      rig.Advance(3 * period_ns);
      for (int m = 0; m < 3; ++m) (void)rig.drive->WritePosition_rad(1.0);
    }
    (void)rig.Cycle(1.0);
  }
  EXPECT_EQ(rig.drive->counters().syncs_skipped, 9u);
  int syncs = 0;
  bool rpdo_since_sync = false;
  std::int32_t target = 0;
  std::int32_t previous_target = 0;
  std::uint64_t previous_sync_ns = 0;
  // The step in counts, plus the rounding of each target to whole counts.
  const double step_counts = std::ceil(2.0 * 1e-3 / rig.config.scaling.position_rad_per_count);
  for (std::size_t i = 0; i < rig.captured.size(); ++i) {
    const proto::can::CanFrame& f = rig.captured[i];
    if (f.id == 0x201) {
      rpdo_since_sync = true;
      target = static_cast<std::int32_t>(static_cast<std::uint32_t>(f.data[2]) | std::uint32_t{f.data[3]} << 8 |
                                         std::uint32_t{f.data[4]} << 16 | std::uint32_t{f.data[5]} << 24);
    }
    if (f.id != 0x080) continue;
    EXPECT_TRUE(rpdo_since_sync) << "SYNC " << syncs << " without its RPDO before it";
    rpdo_since_sync = false;
    if (syncs > 0) {
      EXPECT_LE(std::abs(target - previous_target), step_counts) << "SYNC " << syncs;
      EXPECT_GE(rig.captured_ns[i] - previous_sync_ns, period_ns / 2) << "SYNC " << syncs;
    }
    previous_target = target;
    previous_sync_ns = rig.captured_ns[i];
    ++syncs;
  }
  EXPECT_EQ(syncs, 30);
  EXPECT_EQ(rig.sim->counters().syncs, rig.drive->counters().syncs_sent);
}

// A setpoint carries its unit: a torque given to a position drive is not taken as radians. The hold target goes out
// instead (the last position), the call says kWrongMode and the client counts it.
TEST(Cia402Modes, ASetpointOfAnotherModeSendsTheHoldTargetAndSaysSo) {
  Cia402Rig rig;
  rig.config.mode = Cia402Mode::kCyclicSynchronousPosition;
  rig.sim_config.position_rad_per_count = 1.0 / 4096.0;
  rig.Build();
  rig.BringUp();
  rig.capture = true;
  ASSERT_EQ(rig.Cycle(0.5).write, Cia402Status::kOk);
  const std::string held = LastRpdo(rig);
  EXPECT_EQ(held, "201#0F0000080000");  // 0.5 rad = 2048 counts
  EXPECT_EQ(rig.drive->WriteTorque_Nm(0.1), Cia402Status::kWrongMode);
  rig.Advance(1'000'000);
  EXPECT_EQ(LastRpdo(rig), held);
  EXPECT_EQ(rig.drive->WriteVelocity_rad_per_s(3.0), Cia402Status::kWrongMode);
  rig.Advance(1'000'000);
  EXPECT_EQ(LastRpdo(rig), held);
  EXPECT_EQ(rig.drive->counters().wrong_mode_setpoints, 2u);
  EXPECT_NEAR(rig.drive->position_target_rad(), 0.5, 1e-12);
}

TEST(Cia402Modes, AModeTheDriveDoesNotListIsRefusedAndNothingIsEnabled) {
  Cia402Rig rig;
  rig.sim_config.supported_modes = 1u << 9;  // torque only
  rig.config.mode = Cia402Mode::kCyclicSynchronousPosition;
  rig.Build();
  const std::string e = ThrownBy([&] { rig.drive->Configure(); });
  EXPECT_NE(e.find("the drive does not support cyclic synchronous position (0x6502 = 0x00000200, bit 7 clear)"),
            std::string::npos)
      << e;
  EXPECT_THROW(rig.drive->Activate(), Error);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kSwitchOnDisabled);
  EXPECT_EQ(rig.sim->nmt_state(), canopen::NmtState::kPreOperational);
  EXPECT_EQ(rig.sim->mode_of_operation(), 0);
}

TEST(Cia402Modes, ADriveThatRefusesTheModeWriteIsReportedWithTheAbort) {
  Cia402Rig rig;
  rig.config.mode = Cia402Mode::kCyclicSynchronousVelocity;
  rig.Build();
  rig.sim->AbortObject(cia402::obj::kModesOfOperation, canopen::sdo_abort::kValueRange);
  const std::string e = ThrownBy([&] { rig.drive->Configure(); });
  EXPECT_NE(e.find("0x6060:00 on node 1 aborted: 0x06090030 Invalid value for parameter"), std::string::npos) << e;
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kSwitchOnDisabled);
}

TEST(Cia402Modes, AnRpdoWithoutTheModesTargetIsAConfigurationError) {
  Cia402DriveConfig c;
  c.mode = Cia402Mode::kCyclicSynchronousPosition;
  c.rpdos = Cia402DriveConfig::DefaultRpdos(Cia402Mode::kCyclicSynchronousVelocity);
  transport::EmulatedCanBus bus(transport::EmulatedCanBusConfig{});
  auto port = bus.MakePort(bus.AddNode());
  const std::string e = ThrownBy([&] { Cia402Drive d(c, *port); });
  EXPECT_NE(e.find("position mode: rpdos must map the controlword 0x6040 (16 bits) and the target position 0x607A"),
            std::string::npos)
      << e;
  Cia402Mode m{};
  EXPECT_TRUE(ParseCia402Mode("csv", m));
  EXPECT_EQ(m, Cia402Mode::kCyclicSynchronousVelocity);
  EXPECT_FALSE(ParseCia402Mode("profile position", m));
}

/// Runs velocity mode at 5 rad/s, then requests quick stop; returns the rig after `after_ms` of quick stop.
void QuickStopAt5RadPerS(Cia402Rig& rig, std::int16_t option) {
  rig.config.mode = Cia402Mode::kCyclicSynchronousVelocity;
  rig.config.quick_stop_option_code = option;
  rig.Build();
  rig.BringUp();
  for (int k = 0; k < 200; ++k) (void)rig.Cycle(5.0);
  ASSERT_NEAR(rig.sim->velocity_rad_per_s(), 5.0, 0.01);
  rig.drive->RequestQuickStop();
}

// Quick stop deceleration 0x6085 = 2000 rad/s², but the torque limit (0x6072 = 500 ‰ of 1 N·m on J = 1e-3 kg·m²)
// allows 500 rad/s²: 5 rad/s stop in ~10 ms. Profile deceleration 0x6084 = 200 rad/s²: 25 ms.
TEST(Cia402Modes, QuickStopOption2RampsToRestThenSwitchOnDisabled) {
  Cia402Rig rig;
  QuickStopAt5RadPerS(rig, 2);
  for (int k = 0; k < 5; ++k) (void)rig.Cycle(5.0);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kQuickStopActive);  // braking: still powered
  // ~4 ms of braking at 500 rad/s² (the first ~1 ms goes to the SYNC, the loop's error build-up and the torque lag).
  EXPECT_NEAR(rig.sim->velocity_rad_per_s(), 5.0 - 500 * 4e-3, 0.5);
  for (int k = 0; k < 15; ++k) (void)rig.Cycle(5.0);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kSwitchOnDisabled);
  EXPECT_NEAR(rig.sim->velocity_rad_per_s(), 0.0, 0.05);
}

TEST(Cia402Modes, QuickStopOption1UsesTheProfileDeceleration) {
  Cia402Rig rig;
  QuickStopAt5RadPerS(rig, 1);
  for (int k = 0; k < 10; ++k) (void)rig.Cycle(5.0);
  // 10 ms at 200 rad/s² from 5 rad/s: 3 rad/s (±1 ms of SYNC timing: ±0.2 rad/s, plus the loop's lag).
  EXPECT_NEAR(rig.sim->velocity_rad_per_s(), 3.0, 0.35);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kQuickStopActive);
  for (int k = 0; k < 30; ++k) (void)rig.Cycle(5.0);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kSwitchOnDisabled);
}

TEST(Cia402Modes, QuickStopOption0DisablesAtOnceAndTheJointCoasts) {
  Cia402Rig rig;
  QuickStopAt5RadPerS(rig, 0);
  for (int k = 0; k < 5; ++k) (void)rig.Cycle(5.0);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kSwitchOnDisabled);
  // Coasting: J dω/dt = −bω − τc: 5 ms lose ~0.05 rad/s (b/J = 2 /s, τc/J = 5 rad/s²).
  EXPECT_GT(rig.sim->velocity_rad_per_s(), 4.9);
}

TEST(Cia402Modes, QuickStopOption6HoldsInQuickStopActiveUntilEnabledAgain) {
  Cia402Rig rig;
  QuickStopAt5RadPerS(rig, 6);
  for (int k = 0; k < 20; ++k) (void)rig.Cycle(5.0);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kQuickStopActive);
  const double held = rig.sim->position_rad();
  for (int k = 0; k < 50; ++k) (void)rig.Cycle(5.0);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kQuickStopActive);
  EXPECT_NEAR(rig.sim->position_rad(), held, 1e-3);  // held by the position loop
  // Transition 16: Enable Operation from Quick Stop Active.
  rig.drive->Activate();
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kOperationEnabled);
  Cia402Rig::CycleResult r{};
  for (int k = 0; k < 200; ++k) r = rig.Cycle(5.0);
  EXPECT_NEAR(r.reading.velocity_rad_per_s, 5.0, 2.0 / 4096);
}

TEST(Cia402Modes, DeactivateInQuickStopActiveDisablesTheVoltage) {
  // Shutdown is no transition out of Quick Stop Active (options 5..8 stay there): Disable Voltage (12) is.
  Cia402Rig rig;
  QuickStopAt5RadPerS(rig, 6);
  for (int k = 0; k < 20; ++k) (void)rig.Cycle(5.0);
  ASSERT_EQ(rig.sim->drive_state(), DriveState::kQuickStopActive);
  EXPECT_TRUE(rig.drive->Deactivate());
  rig.Advance(2'000'000);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kReadyToSwitchOn);
}

TEST(Cia402Modes, AModeDisplayThatFollowsLateIsWaitedFor) {
  // A drive switches modes in its own cycle: 0x6061 may show the old mode for a while after 0x6060 is written.
  Cia402Rig rig;
  rig.config.mode = Cia402Mode::kCyclicSynchronousVelocity;
  rig.sim_config.mode_display_delay_ms = 20.0;
  rig.Build();
  rig.BringUp();
  EXPECT_TRUE(rig.drive->active());
  EXPECT_EQ(rig.sim->mode_of_operation(), 9);

  Cia402Rig late;
  late.config.mode = Cia402Mode::kCyclicSynchronousVelocity;
  late.sim_config.mode_display_delay_ms = 800.0;  // beyond state_timeout_ms (500)
  late.Build();
  const std::string e = ThrownBy([&] { late.drive->Configure(); });
  EXPECT_NE(e.find("modes of operation display 0x6061 is 0 500 ms after writing 9 to 0x6060"), std::string::npos) << e;
  EXPECT_FALSE(late.drive->active());
}

TEST(Cia402Modes, HaltStopsAndHoldsInOperationEnabledAndResumes) {
  Cia402Rig rig;
  rig.config.mode = Cia402Mode::kCyclicSynchronousVelocity;
  rig.config.halt_option_code = 2;  // quick stop deceleration: at the torque limit here, ~10 ms from 5 rad/s
  rig.Build();
  rig.BringUp();
  Cia402Rig::CycleResult r{};
  for (int k = 0; k < 200; ++k) r = rig.Cycle(5.0);
  rig.drive->RequestHalt(true);
  for (int k = 0; k < 20; ++k) r = rig.Cycle(5.0);
  EXPECT_EQ(rig.sim->drive_state(), DriveState::kOperationEnabled);
  EXPECT_EQ(r.read, Cia402Status::kOk);
  EXPECT_NEAR(r.reading.velocity_rad_per_s, 0.0, 0.05);
  EXPECT_NE(r.reading.statusword & cia402::sw::kTargetReached, 0);   // bit 10: at rest
  EXPECT_EQ(r.reading.statusword & cia402::sw::kFollowsCommand, 0);  // bit 12: not following the target
  rig.drive->RequestHalt(false);
  for (int k = 0; k < 200; ++k) r = rig.Cycle(5.0);
  EXPECT_NEAR(r.reading.velocity_rad_per_s, 5.0, 2.0 / 4096);
}

// The cycle in position and velocity mode allocates nothing either (the rig's capture is off; the drive simulation
// and the bus allocate nothing after set-up).
TEST(Cia402Modes, ReadAndWriteDoNotAllocateInPositionAndVelocityMode) {
  for (const Cia402Mode mode : {Cia402Mode::kCyclicSynchronousPosition, Cia402Mode::kCyclicSynchronousVelocity}) {
    Cia402Rig rig;
    rig.config.mode = mode;
    rig.config.max_velocity_rad_per_s = 5.0;
    rig.Build();
    rig.BringUp();
    (void)rig.Cycle(0.0);
    int ok = 0;
    ::teleop::test::AllocationCounter counter;
    for (int k = 0; k < 200; ++k) {
      const Cia402Rig::CycleResult r = rig.Cycle(0.5 * std::sin(k * 0.05));
      ok += r.read == Cia402Status::kOk && r.write == Cia402Status::kOk ? 1 : 0;
    }
    EXPECT_EQ(counter.count(), 0u) << ToString(mode);
    EXPECT_EQ(ok, 200) << ToString(mode);
  }
}

TEST(Cia402Modes, TorqueModeStaysTheDefaultWithItsMapping) {
  Cia402DriveConfig c;
  EXPECT_EQ(c.mode, Cia402Mode::kCyclicSynchronousTorque);
  Cia402Rig rig;
  rig.capture = true;
  rig.Build();
  rig.BringUp();
  (void)rig.Cycle(0.1);
  EXPECT_EQ(LastRpdo(rig), "201#0F006400");  // 100 ‰ of 1 N·m (docs/cia402-bringup.log)
}

}  // namespace
}  // namespace teleop::fieldbus
