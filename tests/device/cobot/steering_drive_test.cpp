// The cobot's steering motor on a CiA 402 drive, against the simulated drive on the emulated bus (the same bytes as
// a real drive): the steering loop closes through the PDOs, and each steering fault locks the steering.
#include <gtest/gtest.h>

#include <cmath>

#include "device/cobot/cobot_steering_drive.hpp"
#include "fieldbus/cia402_test_rig.hpp"
#include "teleop/error.hpp"

namespace teleop::device::cobot {
namespace {

using fieldbus::test::Cia402Rig;

constexpr double kTau_s = 0.02;

struct SteeringRig {
  Cia402Rig bus;
  std::unique_ptr<CobotSteeringDrive> steering;
  double k2 = 0.0;

  SteeringRig() {
    bus.Build();
    CobotSteeringDriveConfig config;
    config.drive = bus.config;
    steering = std::make_unique<CobotSteeringDrive>(config, *bus.host_port, bus.Clock());
    steering->Configure();
    steering->Activate();
    k2 = bus.sim_config.joint.inertia_kg_m2 / kTau_s;
  }
  /// One 1 ms cycle of the steering-velocity loop Γ = K₂(ω_c − ω) (eq 3c); returns the sample.
  SteeringSample Cycle(double rate_command_rad_per_s, SteeringFault& fault) {
    SteeringSample s;
    (void)steering->Read(s);
    fault = steering->Write(k2 * (rate_command_rad_per_s - s.rate_rad_per_s));
    bus.Advance(static_cast<std::uint64_t>(bus.config.cycle_period_s * 1e9));
    fault = steering->Read(s);
    return s;
  }
};

TEST(CobotSteeringDrive, SteeringVelocityLoopClosesThroughThePdos) {
  SteeringRig rig;
  SteeringFault fault = SteeringFault::kNone;
  SteeringSample s;
  for (int k = 0; k < 300; ++k) s = rig.Cycle(2.0, fault);
  EXPECT_EQ(fault, SteeringFault::kNone);
  // A proportional loop against the joint's friction: within 15 % of the command after 15 τ.
  EXPECT_NEAR(s.rate_rad_per_s, 2.0, 0.3);
  EXPECT_NEAR(rig.bus.sim->velocity_rad_per_s(), s.rate_rad_per_s, 0.05);
  EXPECT_GT(s.angle_rad, 0.3);
}

TEST(CobotSteeringDrive, HeartbeatTimeoutLocksAndRequestsTheBrake) {
  SteeringRig rig;
  SteeringFault fault = SteeringFault::kNone;
  for (int k = 0; k < 100; ++k) (void)rig.Cycle(1.0, fault);
  rig.bus.sim->SetHeartbeatMuted(true);
  int cycles = 0;
  while (fault == SteeringFault::kNone && cycles < 1000) {
    (void)rig.Cycle(1.0, fault);
    ++cycles;
  }
  EXPECT_EQ(fault, SteeringFault::kHeartbeatLost);
  EXPECT_GT(cycles, 100);  // the consumer's 150 ms timeout, not sooner
  EXPECT_TRUE(rig.steering->locked());
  EXPECT_TRUE(rig.steering->brake_requested());
  // From now on no torque reaches the motor, whatever the controller asks: the steering coasts to a stop.
  for (int k = 0; k < 500; ++k) (void)rig.Cycle(5.0, fault);
  EXPECT_NEAR(rig.bus.sim->applied_torque_Nm(), 0.0, 1e-3);
  EXPECT_NEAR(rig.bus.sim->velocity_rad_per_s(), 0.0, 0.05);
}

TEST(CobotSteeringDrive, LostDriveLocks) {
  SteeringRig rig;
  SteeringFault fault = SteeringFault::kNone;
  for (int k = 0; k < 50; ++k) (void)rig.Cycle(1.0, fault);
  rig.bus.sim->SetSilent(true);
  for (int k = 0; k < 50 && fault == SteeringFault::kNone; ++k) (void)rig.Cycle(1.0, fault);
  EXPECT_EQ(fault, SteeringFault::kDriveLost);
  EXPECT_TRUE(rig.steering->brake_requested());
}

TEST(CobotSteeringDrive, DriveFaultLocks) {
  SteeringRig rig;
  SteeringFault fault = SteeringFault::kNone;
  for (int k = 0; k < 50; ++k) (void)rig.Cycle(1.0, fault);
  rig.bus.sim->InjectFault(0x2310);  // over-current
  for (int k = 0; k < 50 && fault == SteeringFault::kNone; ++k) (void)rig.Cycle(1.0, fault);
  EXPECT_EQ(fault, SteeringFault::kDriveFault);
}

TEST(CobotSteeringDrive, EncoderJumpHoldsTheSteeringWhereItIs) {
  SteeringRig rig;
  SteeringFault fault = SteeringFault::kNone;
  SteeringSample s;
  for (int k = 0; k < 200; ++k) s = rig.Cycle(1.0, fault);
  const double before = s.angle_rad;
  // The joint is knocked by 0.6 rad in one cycle (or the count jumps): beyond max_angle_jump_rad = 0.2.
  rig.bus.sim->SetJointState(rig.bus.sim->position_rad() + 0.6, rig.bus.sim->velocity_rad_per_s());
  s = rig.Cycle(1.0, fault);
  EXPECT_EQ(fault, SteeringFault::kEncoderJump);
  EXPECT_NEAR(rig.steering->lock_angle_rad(), before, 0.01);  // the last trusted angle
  const double held_at = rig.bus.sim->position_rad();
  // The controller keeps asking for 1 rad/s; the hold keeps the wheel where it is (within 0.05 rad over 1 s).
  for (int k = 0; k < 1000; ++k) s = rig.Cycle(1.0, fault);
  EXPECT_NEAR(rig.bus.sim->position_rad(), held_at, 0.05);
  EXPECT_EQ(fault, SteeringFault::kEncoderJump);
  // Activate() clears the latch.
  rig.steering->Activate();
  EXPECT_FALSE(rig.steering->locked());
}

TEST(CobotSteeringDrive, BadConfigIsRejected) {
  Cia402Rig bus;
  bus.Build();
  CobotSteeringDriveConfig config;
  config.drive = bus.config;
  config.gear_ratio = 0.0;
  EXPECT_THROW(CobotSteeringDrive(config, *bus.host_port, bus.Clock()), Error);
}

}  // namespace
}  // namespace teleop::device::cobot
