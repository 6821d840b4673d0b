// The host side of MIT-mode motors (MitMotorBus) against the simulated motor on the in-process emulated bus, on a
// manual clock: the exchange, the motor's own PD, its CAN timeout, fault codes by name, missing replies, register
// access and the range check (docs/mit-motors.md).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "teleop/error.hpp"
#include "teleop/fieldbus/mit_motor_bus.hpp"
#include "teleop/fieldbus/simulated_mit_motor.hpp"
#include "teleop/transport/can_emulated_bus.hpp"

namespace teleop::fieldbus {
namespace {

namespace mit = proto::can::mit;

struct MitRig {
  std::uint64_t now_ns = 0;
  transport::EmulatedCanBus bus{transport::EmulatedCanBusConfig{}, [this] { return now_ns; }};
  SimulatedMitMotorConfig sim_config;
  std::unique_ptr<transport::CanPort> host_port;
  std::unique_ptr<transport::CanPort> motor_port;
  std::unique_ptr<SimulatedMitMotor> motor;
  std::unique_ptr<MitMotorBus> host;

  explicit MitRig(mit::MotorRanges host_ranges = {}) {
    const int h = bus.AddNode();
    const int m = bus.AddNode();
    MitMotorConfig mc;
    mc.name = "joint 1";
    mc.ranges = host_ranges;
    const std::vector<MitMotorConfig> motors{mc};
    host_port = bus.MakePort(h, MitMotorBus::ReceiveOptions(motors));
    motor_port = bus.MakePort(m, SimulatedMitMotor::ReceiveOptions(sim_config));
    motor = std::make_unique<SimulatedMitMotor>(sim_config, *motor_port);
    Timebase t;
    t.now_ns = [this] { return now_ns; };
    t.wait_ns = [this](std::uint64_t ns) { Advance(ns); };
    host = std::make_unique<MitMotorBus>(*host_port, motors, false, t);
    motor->Step(static_cast<std::int64_t>(now_ns));
  }
  void Advance(std::uint64_t ns) {
    const std::uint64_t end = now_ns + ns;
    while (now_ns < end) {
      now_ns = std::min(end, now_ns + 100'000);
      bus.Run();
      motor->Step(static_cast<std::int64_t>(now_ns));
      bus.Run();
    }
  }
  /// `n` 1 ms cycles of one exchange each.
  void Cycles(int n) {
    for (int k = 0; k < n; ++k) {
      (void)host->Exchange();
      Advance(1'000'000);
    }
  }
};

TEST(MitMotorBus, TorqueCommandsTurnTheShaftAndTheFeedbackFollowsIt) {
  MitRig rig;
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kEnable, 0.01).empty());
  EXPECT_TRUE(rig.motor->enabled());
  rig.host->SetCommand(0, mit::Command{0, 0, 0, 0, 0.5});
  rig.Cycles(200);
  const MitMotorState& s = rig.host->state(0);
  ASSERT_TRUE(s.answered);
  EXPECT_EQ(s.feedback.status, 1);
  EXPECT_EQ(s.missing, 0U);
  EXPECT_NEAR(s.feedback.torque_Nm, 0.5, 20.0 / 4095.0);  // one step of the 12-bit torque
  EXPECT_GT(rig.motor->velocity_rad_per_s(), 1.0);
  // The feedback is the reply to the last exchange: within one cycle's travel and one step of 16 bits.
  // The feedback read at the last exchange answered the exchange before it: about two cycles of travel behind.
  EXPECT_NEAR(s.feedback.position_rad, rig.motor->position_rad(),
              std::abs(rig.motor->velocity_rad_per_s()) * 2.1e-3 + 25.0 / 65535.0);
  EXPECT_GT(s.feedback.position_rad, 1.0);
}

TEST(MitMotorBus, TheMotorsOwnPdHoldsAPositionTarget) {
  MitRig rig;
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kEnable, 0.01).empty());
  rig.host->SetCommand(0, mit::Command{0.8, 0, 20.0, 0.5, 0});
  rig.Cycles(1500);
  EXPECT_LT(std::abs(rig.motor->velocity_rad_per_s()), 1e-6);  // creeping onto the edge of the friction band
  // At rest where Kp·(p − θ) + Kd·v + τ_ff is within Coulomb friction (0.05 N·m), with the values the motor decoded:
  // Kp 163 steps of 500/4095, Kd 409 of 5/4095, p 34864 of 25/65535 − 12.5, and the mid-scale v and τ that are not
  // quite zero (2047 steps: −0.0073 rad/s, −0.0024 N·m), as on a real motor.
  const double kp = 163 * 500.0 / 4095.0;
  const double offset = 409 * 5.0 / 4095.0 * (2047 * 60.0 / 4095.0 - 30.0) + (2047 * 20.0 / 4095.0 - 10.0);
  const double p = 34864 * 25.0 / 65535.0 - 12.5;
  EXPECT_GE(rig.motor->position_rad(), p + (offset - 0.05) / kp - 1e-9);
  EXPECT_LE(rig.motor->position_rad(), p + (offset + 0.05) / kp + 1e-9);
  EXPECT_NEAR(rig.host->state(0).feedback.position_rad, rig.motor->position_rad(), 1e-3);
}

TEST(MitMotorBus, ADisabledMotorGivesNoTorqueAndSetZeroMovesItsZero) {
  MitRig rig;
  rig.host->SetCommand(0, mit::Command{0, 0, 0, 0, 2.0});
  rig.Cycles(50);
  EXPECT_EQ(rig.host->state(0).feedback.status, 0);
  EXPECT_EQ(rig.motor->velocity_rad_per_s(), 0.0);
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kEnable, 0.01).empty());
  rig.Cycles(50);
  const double moved = rig.motor->position_rad();
  EXPECT_GT(moved, 0.05);
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kDisable, 0.01).empty());
  rig.Advance(5'000'000'000);  // coast to rest (Coulomb friction: 28 rad/s² at most)
  ASSERT_EQ(rig.motor->velocity_rad_per_s(), 0.0);
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kSetZero, 0.01).empty());
  EXPECT_NEAR(rig.motor->position_rad(), 0.0, 1e-12);
  EXPECT_NEAR(rig.host->state(0).feedback.position_rad, 0.0, 25.0 / 65535.0);
}

TEST(MitMotorBus, TheStateAfterADisableIsTheAnswerToIt) {
  // The last command's feedback is still on its way when the disable goes out (the tools' stop): the state read
  // afterwards must be the disable's answer, not that late feedback.
  MitRig rig;
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kEnable, 0.01).empty());
  rig.host->SetCommand(0, mit::Command{0, 0, 0, 0, 0.5});
  rig.Cycles(5);
  (void)rig.host->Exchange();
  rig.Advance(150'000);  // the motor has the command; its feedback is on the wire when the disable goes out
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kDisable, 0.01).empty());
  EXPECT_FALSE(rig.motor->enabled());
  EXPECT_EQ(rig.host->state(0).feedback.status, 0) << "the late feedback of the last command was taken as the answer";
}

TEST(MitMotorBus, TheMotorsTimeoutDisablesItWhenTheHostFallsSilent) {
  MitRig rig;
  ASSERT_TRUE(rig.host->WriteRegister(0, static_cast<std::uint8_t>(mit::Register::kTimeout), 400, 0.01));  // 20 ms
  EXPECT_EQ(rig.motor->timeout_counts(), 400U);
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kEnable, 0.01).empty());
  rig.host->SetCommand(0, mit::Command{0, 0, 0, 0, 1.0});
  rig.Cycles(30);
  EXPECT_TRUE(rig.motor->enabled());
  rig.Advance(19'000'000);  // the host dies: no frame for 19 ms
  EXPECT_TRUE(rig.motor->enabled());
  rig.Advance(2'000'000);  // 21 ms
  EXPECT_FALSE(rig.motor->enabled());
  EXPECT_EQ(rig.motor->torque_Nm(), 0.0);
  rig.Cycles(2);  // a host that comes back reads the code
  EXPECT_EQ(rig.host->state(0).feedback.status, static_cast<std::uint8_t>(mit::MotorStatus::kCommunicationLost));
  EXPECT_EQ(mit::StatusName(rig.host->state(0).feedback.status), "communication lost");
  // Enable is refused until the error is cleared.
  (void)rig.host->SendSpecialAndWait(mit::Special::kEnable, 0.01);
  EXPECT_FALSE(rig.motor->enabled());
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kClearError, 0.01).empty());
  EXPECT_EQ(rig.host->state(0).feedback.status, 0);
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kEnable, 0.01).empty());
  EXPECT_TRUE(rig.motor->enabled());
}

TEST(MitMotorBus, AnInjectedOverTemperatureIsReportedByNameAndStopsTheTorque) {
  MitRig rig;
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kEnable, 0.01).empty());
  rig.host->SetCommand(0, mit::Command{0, 0, 0, 0, 1.0});
  rig.Cycles(10);
  rig.motor->InjectFault(mit::MotorStatus::kCoilOverTemperature);
  rig.Cycles(3);
  const MitMotorState& s = rig.host->state(0);
  EXPECT_EQ(mit::StatusName(s.feedback.status), "coil over-temperature");
  EXPECT_TRUE(mit::IsFault(s.feedback.status));
  EXPECT_GT(s.feedback.rotor_temperature_C, 100.0);
  EXPECT_EQ(rig.motor->torque_Nm(), 0.0);
  // Clear error does nothing while the cause is there.
  (void)rig.host->SendSpecialAndWait(mit::Special::kClearError, 0.01);
  EXPECT_TRUE(mit::IsFault(rig.host->state(0).feedback.status));
}

TEST(MitMotorBus, AMotorThatStopsAnsweringIsCountedInARow) {
  MitRig rig;
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kEnable, 0.01).empty());
  rig.Cycles(10);
  EXPECT_EQ(rig.host->state(0).missing_in_a_row, 0);
  rig.motor->SetSilent(true);
  rig.Cycles(6);
  EXPECT_EQ(rig.host->state(0).missing_in_a_row, 5);  // the 6th exchange's reply is not due yet
  EXPECT_EQ(rig.host->state(0).missing, 5U);
  rig.motor->SetSilent(false);
  rig.Cycles(2);
  EXPECT_EQ(rig.host->state(0).missing_in_a_row, 0);
  EXPECT_EQ(rig.host->state(0).missing, 6U);  // the 6th command, sent while silent, never got its reply
  // A silent motor is named by SendSpecialAndWait.
  rig.motor->SetSilent(true);
  EXPECT_EQ(rig.host->SendSpecialAndWait(mit::Special::kDisable, 0.005), std::vector<std::size_t>{0});
}

TEST(MitMotorBus, RegistersAndTheRangeCheck) {
  MitRig rig;
  const auto pmax = rig.host->ReadRegister(0, static_cast<std::uint8_t>(mit::Register::kPositionMax), 0.01);
  ASSERT_TRUE(pmax.has_value());
  const mit::Parameter answer{0, mit::ParameterOp::kRead, 0, *pmax};
  EXPECT_FLOAT_EQ(answer.FloatValue(), 12.5F);
  EXPECT_EQ(rig.host->ReadRegister(0, static_cast<std::uint8_t>(mit::Register::kMasterId), 0.01), 0x11U);
  EXPECT_NO_THROW(rig.host->VerifyRanges(0, 0.01));
  // A host configured for a DM-J4340 (T_MAX 28) against a motor with T_MAX 10: refused, naming the register.
  MitRig wrong(mit::MotorRanges{12.5, 30.0, 28.0, 500.0, 5.0});
  try {
    wrong.host->VerifyRanges(0, 0.01);
    FAIL() << "a range mismatch must be refused";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("T_MAX (register 23) is 10"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("joint 1"), std::string::npos) << e.what();
  }
  // Writes only while disabled.
  ASSERT_TRUE(rig.host->SendSpecialAndWait(mit::Special::kEnable, 0.01).empty());
  EXPECT_FALSE(rig.host->WriteRegister(0, static_cast<std::uint8_t>(mit::Register::kTimeout), 100, 0.005));
  // A motor that is not there.
  rig.motor->SetSilent(true);
  EXPECT_FALSE(rig.host->ReadRegister(0, static_cast<std::uint8_t>(mit::Register::kEscId), 0.005).has_value());
  EXPECT_THROW(rig.host->VerifyRanges(0, 0.005), Error);
}

TEST(MitMotorBus, BadConfigsAreRefused) {
  transport::EmulatedCanBus bus{transport::EmulatedCanBusConfig{}};
  auto port = bus.MakePort(bus.AddNode());
  MitMotorConfig a;
  MitMotorConfig b;
  b.esc_id = 0x02;
  b.master_id = 0x11;  // same as a's
  EXPECT_THROW(MitMotorBus(*port, {a, b}), Error);
  b.master_id = 0x7FF;
  EXPECT_THROW(MitMotorBus(*port, {a, b}), Error);
  b.master_id = 0x12;
  b.ranges.torque_max_Nm = std::nan("");
  EXPECT_THROW(MitMotorBus(*port, {a, b}), Error);
  EXPECT_THROW(MitMotorBus(*port, {}), Error);
  b.ranges.torque_max_Nm = 10;
  EXPECT_NO_THROW(MitMotorBus(*port, {a, b}));
}

}  // namespace
}  // namespace teleop::fieldbus
