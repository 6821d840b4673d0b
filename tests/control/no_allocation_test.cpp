// The control-cycle calls (law, fixture, estimator, plant Read/Write/Update) make no heap allocation.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>

#include "teleop/control/three_channel_law.hpp"
#include "teleop/device/loopback.hpp"
#include "test_utilities/limit_malloc.hpp"

namespace teleop {
namespace {

TEST(NoAllocation, TheCounterSeesAnAllocation) {
  test::AllocationCounter counter;
  auto p = std::make_unique<double>(1.0);
  EXPECT_GE(counter.count(), 1u);
  EXPECT_EQ(*p, 1.0);
}

// At the most DOF the framework carries (kMaxDof, 12).
control::ThreeChannelLaw::Config MaxDofLaw() {
  static_assert(kMaxDof == 12);
  auto config = control::ThreeChannelLaw::ZeroGains(Role::kSlave, kMaxDof);
  config.kp_N_per_m.setConstant(600.0);
  config.kd_Ns_per_m.setConstant(2.0);
  config.kv_Ns_per_m.setConstant(0.5);
  config.max_force_N = 3.0;
  config.velocity_filter_hz = 200.0;
  config.fixture.dof = kMaxDof;
  config.fixture.stiffness_N_per_m = 2000.0;
  config.fixture.plane_count = 3;
  for (int i = 0; i < 3; ++i) {
    config.fixture.planes[static_cast<std::size_t>(i)].normal = DofVector::Unit(kMaxDof, i);
    config.fixture.planes[static_cast<std::size_t>(i)].offset_m = 0.001;
  }
  return config;
}

TEST(NoAllocation, LawFixtureAndEstimatorStep) {
  control::ThreeChannelLaw law(MaxDofLaw());
  control::ForbiddenRegionFixture fixture(MaxDofLaw().fixture);
  control::VelocityEstimator estimator({kMaxDof, 200.0});
  control::ThreeChannelLaw::Input in;
  in.position_m = DofVector::Constant(kMaxDof, 0.002);
  in.peer_position_m = DofVector::Constant(kMaxDof, 0.01);
  in.peer_velocity_m_per_s = DofVector::Constant(kMaxDof, 0.1);
  in.peer_force_N = DofVector::Constant(kMaxDof, 1.0);
  in.peer_valid = true;
  double sink = 0.0;
  {
    test::AllocationCounter counter;
    for (int k = 0; k < 1000; ++k) {
      in.position_m[0] = 0.002 + 1e-6 * k;
      in.peer_valid = (k % 7) != 0;
      const auto out = law.Step(in, 0.001);
      sink += out.command_N.sum();
      sink += fixture.Step(in.position_m).force_N.sum();
      sink += estimator.Step(in.position_m, 0.001).sum();
    }
    in.position_m[1] = std::numeric_limits<double>::quiet_NaN();  // the bad-input path too
    sink += law.Step(in, 0.001).command_N.sum();
    EXPECT_EQ(counter.count(), 0u);
  }
  EXPECT_TRUE(std::isfinite(sink));
}

TEST(NoAllocation, PlantReadWriteUpdateIncludingContactAndNewPeriods) {
  device::LoopbackPlantConfig config = device::LoopbackPlantConfig::PaperSlave(2);
  config.encoder_resolution_m = 1e-5;
  config.environment.kind = device::SimulatedEnvironmentConfig::Kind::kWall;
  config.environment.axis = 0;
  config.environment.position_m = 0.001;
  config.environment.stiffness_N_per_m = 5000.0;
  config.environment.damping_Ns_per_m = 1.0;
  config.human.enabled = true;
  config.human.mass_kg = 0.01;
  config.human.damping_Ns_per_m = 2.0;
  config.human.stiffness_N_per_m = 200.0;
  config.human.segment_count = 1;
  config.human.segments[0].kind = device::OperatorSegment::Kind::kSine;
  config.human.segments[0].amplitude_N = 1.0;
  config.human.segments[0].frequency_hz = 2.0;
  device::LoopbackPlant plant(config);
  device::Reading reading;
  device::Command command = device::Command::Force(DofVector::Constant(2, 2.0));  // pushes into the wall
  {
    test::AllocationCounter counter;
    for (int k = 0; k < 2000; ++k) {
      plant.Read(reading);
      plant.Write(command);
      plant.Update(k < 1000 ? 0.001 : 0.0005);  // a new period re-derives the exact step
    }
    command.force_N[0] = std::numeric_limits<double>::quiet_NaN();
    plant.Write(command);
    plant.Update(0.001);
    plant.Read(reading);
    EXPECT_EQ(counter.count(), 0u);
  }
  EXPECT_GT(plant.true_position_m()[0], 0.001);  // it did reach the wall
}

}  // namespace
}  // namespace teleop
