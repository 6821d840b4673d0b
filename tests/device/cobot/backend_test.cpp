// The `cobot` backend behind the Device interface: registration and capabilities, its YAML section, and — as a
// master — a fixture plane rendered as a steered wall and a blocked slave rendered as a wall across the contact.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

#include "device/cobot/cobot_backend.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop::device::cobot {
namespace {

constexpr double kPeriod_s = 0.001;

std::any ReadSection(const std::string& yaml, int dof) {
  static const std::string file = "test.yaml";
  const YAML::Node node = YAML::Load(yaml);
  const config::Field field(node, "device.cobot", &file);
  const DeviceBackend* backend = FindDevice("cobot");
  return backend->read(&field, SectionContext{Role::kMaster, dof});
}

TEST(CobotBackend, RegisteredAsAPassiveSteeredDevice) {
  const DeviceBackend* backend = FindDevice("cobot");
  ASSERT_NE(backend, nullptr);
  EXPECT_EQ(backend->nominal.rendering, Rendering::kSteeredConstraints);
  EXPECT_FALSE(backend->nominal.can_push());
  DeviceConfig config = DeviceConfig::Of("cobot", 2, ReadSection("{cart_mass_kg: 5}", 2));
  const std::unique_ptr<Device> device = MakeDevice(config);
  EXPECT_EQ(device->name(), "cobot");
  EXPECT_EQ(device->capabilities().rendering, Rendering::kSteeredConstraints);
  EXPECT_EQ(device->capabilities().max_force_on(0), 0.0);
  const AnalysisModel model = DeviceModel(config);
  EXPECT_FALSE(model.applicable);
  EXPECT_NE(model.reason.find("eq 10"), std::string::npos);
}

TEST(CobotBackend, SectionReaderChecksKeysRangesAndDof) {
  const auto c = std::any_cast<CobotBackendConfig>(
      ReadSection("{cart_mass_kg: 5, steering_time_constant_s: 0.05, lookahead_m: 0.03, overlay: false}", 2));
  EXPECT_DOUBLE_EQ(c.unicycle.controller.caster.k1_per_kg, 0.2);  // 1/K1 is the cart's mass
  EXPECT_NEAR(SteeringTimeConstant_s(c.unicycle.plant, c.unicycle.controller.tracker.k2_Nms_per_rad), 0.05, 1e-12);
  EXPECT_FALSE(c.unicycle.controller.overlay_enabled);
  EXPECT_THROW(ReadSection("{virtual_mas_kg: 5}", 2), Error);                      // unknown key
  EXPECT_THROW(ReadSection("{virtual_mass_kg: -1, cart_mass_kg: -1}", 2), Error);  // range
  EXPECT_THROW(ReadSection("{kind: tricycle}", 2), Error);                         // enum
  EXPECT_THROW(ReadSection("{kind: unicycle}", 3), Error);                         // a unicycle is planar
  EXPECT_THROW(ReadSection("{stability_action: brake}", 2), Error);                // no brake configured
  EXPECT_NO_THROW(ReadSection("{kind: bicycle, bicycle: {half_wheelbase_m: 0.3}}", 3));
  try {
    ReadSection("{lookahead_m: 0}", 2);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lookahead_m"), std::string::npos) << e.what();
  }
}

// The unicycle's caster renders one mass in every direction: along the wheel the operator pushes the cart itself
// (cart_mass_kg), so the caster's 1/K1 across it is the same mass. A virtual_mass_kg that differs (20 kg cart, 10 kg
// caster: 20 kg along, 10 across) is refused with the reason, as the bicycle refuses the key; an equal one is accepted
// (the shipped configs name it), and without it 1/K1 follows the cart.
TEST(CobotBackend, UnicycleVirtualMassIsTheCartMass) {
  const auto follows = std::any_cast<CobotBackendConfig>(ReadSection("{cart_mass_kg: 20}", 2));
  EXPECT_DOUBLE_EQ(1.0 / follows.unicycle.controller.caster.k1_per_kg, 20.0);
  const auto same = std::any_cast<CobotBackendConfig>(ReadSection("{cart_mass_kg: 20, virtual_mass_kg: 20}", 2));
  EXPECT_DOUBLE_EQ(1.0 / same.unicycle.controller.caster.k1_per_kg, 20.0);
  try {
    ReadSection("{cart_mass_kg: 20, virtual_mass_kg: 10}", 2);
    FAIL() << "an anisotropic caster was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("must equal cart_mass_kg"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadSection("{virtual_mass_kg: 5}", 2), Error);  // the default cart is 10 kg
}

CobotBackendConfig PushingAt(double direction_deg) {
  CobotBackendConfig c;
  c.op.enabled = true;
  c.op.speed_m_per_s = 0.2;
  c.op.direction_deg = direction_deg;
  c.initial.heading_rad = direction_deg * std::numbers::pi / 180.0;
  return c;
}

Command WithPlane(double nx, double ny, double offset_m) {
  Command c = Command::Force(DofVector::Zero(2));
  c.constraint_count = 1;
  c.constraints[0].normal = DofVector::Zero(2);
  c.constraints[0].normal << nx, ny;
  c.constraints[0].offset_m = offset_m;
  return c;
}

TEST(CobotBackend, FixturePlaneIsRenderedAsASteeredWall) {
  // The operator pushes at 45° towards a fixture plane y = 0.1 (forbidden above).
  UnicycleCobotDevice with_wall(PushingAt(45.0));
  UnicycleCobotDevice without(PushingAt(45.0));
  const Command plane = WithPlane(0.0, 1.0, 0.1);
  const Command none = Command::Force(DofVector::Zero(2));
  Reading r;
  double max_y = 0.0;
  for (int k = 0; k < 3000; ++k) {
    with_wall.Read(r);
    max_y = std::max(max_y, r.position_m[1]);
    with_wall.Write(plane);
    with_wall.Update(kPeriod_s);
    without.Read(r);
    without.Write(none);
    without.Update(kPeriod_s);
  }
  EXPECT_EQ(with_wall.rendered_wall(), 0);
  EXPECT_LT(max_y, 0.1 + 0.005);                           // held within 5 mm (overlay on)
  EXPECT_GT(with_wall.rig().state().position_m.x(), 0.3);  // while sliding along it
  without.Read(r);
  EXPECT_GT(r.position_m[1], 0.2);  // without it, the cart goes through
  with_wall.Read(r);
  EXPECT_EQ(r.faults, kFaultNone);
}

TEST(CobotBackend, BlockedSlaveIsRenderedAsAWallAcrossTheContact) {
  CobotBackendConfig c = PushingAt(0.0);
  c.op.then_at_s = 2.0;
  c.op.then_direction_deg = 180.0;  // the operator pulls back after 2 s
  UnicycleCobotDevice device(c);
  Reading r;
  double x_at_contact = 0.0;
  double x_at_1500ms = 0.0;
  for (int k = 0; k < 3000; ++k) {
    device.Read(r);
    Command command = Command::Force(DofVector::Zero(2));
    // From 0.5 s to 2.2 s the slave is blocked: the coupling pushes the master back along −x with 6 N.
    const double t = k * kPeriod_s;
    if (t >= 0.5 && t < 2.2) command.force_N[0] = -6.0;
    if (k == 500) x_at_contact = r.position_m[0];
    if (k == 1500) x_at_1500ms = r.position_m[0];
    device.Write(command);
    device.Update(kPeriod_s);
    if (k == 1999) {
      EXPECT_EQ(device.rendered_wall(), UnicycleCobotDevice::kContactWall);
      device.Read(r);
      // A head-on contact is the cobot's worst case (§5: a 90° turn): it cannot stop the cart on the spot, it
      // turns the wheel to the wall's tangent. The cart goes in by a few centimetres (28 mm here), then the
      // operator's head-on push only creeps it in through wheel slip.
      EXPECT_LT(r.position_m[0] - x_at_contact, 0.04);
      EXPECT_LT(r.position_m[0] - x_at_1500ms, 0.005);  // < 1 cm/s during the last half second
      EXPECT_EQ(device.last_sample().control.mode, WallMode::kTracking);
    }
  }
  device.Read(r);
  EXPECT_EQ(device.rendered_wall(), -1);  // contact released once the coupling force dropped
  EXPECT_LT(r.position_m[0], x_at_contact - 0.02)
      << r.position_m.transpose() << " contact at " << x_at_contact << " u " << device.rig().state().speed_m_per_s
      << " heading " << device.rig().state().heading_rad;  // and the operator pulled the cobot back
}

TEST(CobotBackend, BadCommandIsAFaultAndLocksTheSteering) {
  UnicycleCobotDevice device(PushingAt(0.0));
  Command bad = Command::Force(DofVector::Zero(2));
  bad.force_N[1] = std::numeric_limits<double>::quiet_NaN();
  device.Write(bad);
  device.Update(kPeriod_s);
  Reading r;
  device.Read(r);
  EXPECT_EQ(r.faults & kFaultDriver, kFaultDriver);
  EXPECT_TRUE(device.rig().locked());
  Command wrong_size = Command::Force(DofVector::Zero(3));
  device.Write(wrong_size);
  device.Read(r);
  EXPECT_EQ(r.faults & kFaultDriver, kFaultDriver);
  device.Write(Command::Force(DofVector::Zero(2)));  // a good command resumes
  EXPECT_FALSE(device.rig().locked());
  device.SetSafe();
  EXPECT_TRUE(device.rig().locked());
}

TEST(CobotBackend, CycleDoesNotAllocate) {
  UnicycleCobotDevice device(PushingAt(30.0));
  const Command plane = WithPlane(0.0, 1.0, 0.05);
  Reading r;
  device.Read(r);
  device.Write(plane);
  device.Update(kPeriod_s);
  test::AllocationCounter counter;
  for (int k = 0; k < 300; ++k) {
    device.Read(r);
    device.Write(plane);
    device.Update(kPeriod_s);
  }
  EXPECT_EQ(counter.count(), 0u);
}

TEST(CobotBackend, BicycleCycleDoesNotAllocate) {
  // The bicycle's cycle with its sensing (encoders, rate estimates), caster and wall: 2 s at 1 kHz into a plane,
  // caster, overlay and tracking all run.
  CobotBackendConfig c = PushingAt(45.0);
  c.kind = CobotBackendConfig::Kind::kBicycle;
  BicycleCobotDevice device(c);
  Command plane = Command::Force(DofVector::Zero(3));
  plane.constraint_count = 1;
  plane.constraints[0].normal = DofVector::Zero(3);
  plane.constraints[0].normal << 0.0, 1.0, 0.0;
  plane.constraints[0].offset_m = 0.1;
  Reading r;
  device.Read(r);
  device.Write(plane);
  device.Update(kPeriod_s);
  bool tracked = false;
  test::AllocationCounter counter;
  for (int k = 0; k < 2000; ++k) {
    device.Read(r);
    device.Write(plane);
    device.Update(kPeriod_s);
    tracked = tracked || device.controller_mode() == WallMode::kTracking;
  }
  EXPECT_EQ(counter.count(), 0u);
  EXPECT_TRUE(tracked);
}

TEST(CobotBackend, BicycleMovesAsACaster) {
  CobotBackendConfig c = PushingAt(30.0);
  c.kind = CobotBackendConfig::Kind::kBicycle;
  const std::unique_ptr<Device> device = MakeDevice(CobotDeviceConfig(c));
  ASSERT_EQ(device->capabilities().dof, 3);
  Reading r;
  for (int k = 0; k < 2000; ++k) {
    device->Read(r);
    device->Write(Command::Force(DofVector::Zero(3)));
    device->Update(kPeriod_s);
  }
  device->Read(r);
  EXPECT_EQ(r.faults, kFaultNone);
  EXPECT_GT(Vec2(r.position_m[0], r.position_m[1]).norm(), 0.1);
}

struct BicycleWallRun {
  double max_penetration_m = 0.0;
  double x_end_m = 0.0;
  double y_end_m = 0.0;
  WallMode mode_before_release = WallMode::kCaster;
  WallMode mode_end = WallMode::kCaster;
  int engage_count = 0;
  int release_count = 0;
};

/// The bicycle's plate (reference point at its origin) pushed at `approach_deg` from 100 mm below the fixture plane
/// y > 0.1 m, at 0.2 m/s; after 3 s the operator pulls away (−90°).
BicycleWallRun BicycleWallApproach(double approach_deg, bool overlay, double plate_deg) {
  CobotBackendConfig c = PushingAt(approach_deg);
  c.kind = CobotBackendConfig::Kind::kBicycle;
  c.unicycle.controller.overlay_enabled = overlay;
  c.initial.heading_rad = plate_deg * std::numbers::pi / 180.0;  // the plate's θ
  c.op.then_at_s = 3.0;
  c.op.then_direction_deg = -90.0;
  BicycleCobotDevice device(c);
  Command plane = Command::Force(DofVector::Zero(3));
  plane.constraint_count = 1;
  plane.constraints[0].normal = DofVector::Zero(3);
  plane.constraints[0].normal << 0.0, 1.0, 0.0;
  plane.constraints[0].offset_m = 0.1;
  BicycleWallRun run;
  Reading r;
  for (int k = 0; k < 4000; ++k) {
    device.Read(r);
    EXPECT_EQ(r.faults, kFaultNone) << k;
    run.max_penetration_m = std::max(run.max_penetration_m, r.position_m[1] - 0.1);
    if (k == 2999) run.mode_before_release = device.controller().mode();
    device.Write(plane);
    device.Update(kPeriod_s);
  }
  device.Read(r);
  run.x_end_m = r.position_m[0];
  run.y_end_m = r.position_m[1];
  run.mode_end = device.controller().mode();
  run.engage_count = device.controller().engage_count();
  run.release_count = device.controller().release_count();
  return run;
}

TEST(CobotBackend, BicycleRendersAFixturePlaneOnItsReferencePoint) {
  // Wheels start across the approach (the plate at 0°, wheels pointing +x): the caster first turns them.
  for (const double plate_deg : {0.0, 60.0}) {
    SCOPED_TRACE(plate_deg);
    const BicycleWallRun on = BicycleWallApproach(45.0, true, plate_deg);
    const BicycleWallRun off = BicycleWallApproach(45.0, false, plate_deg);
    std::printf("bicycle, plate %.0f deg, 45 deg approach: max penetration %.2f mm overlay on, %.2f mm off\n",
                plate_deg, on.max_penetration_m * 1e3, off.max_penetration_m * 1e3);
    for (const BicycleWallRun* run : {&on, &off}) {
      EXPECT_EQ(run->mode_before_release, WallMode::kTracking);  // held on the wall while pushing into it
      EXPECT_EQ(run->mode_end, WallMode::kCaster);               // released once the force points away
      EXPECT_GE(run->engage_count, 1);
      EXPECT_GE(run->release_count, 1);
      EXPECT_LT(run->y_end_m, 0.1 - 0.05);  // and the plate left the wall
    }
    EXPECT_LT(on.max_penetration_m, 0.006);   // the unicycle's class (5 mm in FixturePlaneIsRenderedAsASteeredWall)
    EXPECT_LT(off.max_penetration_m, 0.030);  // bounded without the overlay too
    EXPECT_LT(on.max_penetration_m, off.max_penetration_m);  // the overlay reduces the penetration
  }
  // Without the plane, the same push goes through.
  CobotBackendConfig c = PushingAt(45.0);
  c.kind = CobotBackendConfig::Kind::kBicycle;
  BicycleCobotDevice free(c);
  Reading r;
  for (int k = 0; k < 3000; ++k) {
    free.Read(r);
    free.Write(Command::Force(DofVector::Zero(3)));
    free.Update(kPeriod_s);
  }
  free.Read(r);
  EXPECT_GT(r.position_m[1], 0.2);
}

}  // namespace
}  // namespace teleop::device::cobot
