// Cost of one control cycle's pieces: law Step (1 and 6 DOF), plant Update (free and in wall contact), and a whole
// in-process closed-loop cycle. Prints numbers; asserts nothing.

#include <benchmark/benchmark.h>

#include "teleop/control/three_channel_law.hpp"
#include "teleop/device/loopback.hpp"

namespace teleop {
namespace {

void BM_LawStep(benchmark::State& state) {
  const int dof = static_cast<int>(state.range(0));
  auto config = control::ThreeChannelLaw::ZeroGains(Role::kMaster, dof);
  config.kp_N_per_m.setConstant(600.0);
  config.kd_Ns_per_m.setConstant(2.0);
  config.kv_Ns_per_m.setConstant(0.5);
  config.kf.setConstant(0.2);
  config.max_force_N = 5.0;
  config.velocity_filter_hz = 200.0;
  config.fixture = control::ForbiddenRegionFixture::HalfSpace(dof, 0, 0.0, 1.0, 2000.0);
  control::ThreeChannelLaw law(config);
  control::ThreeChannelLaw::Input in;
  in.position_m = DofVector::Constant(dof, 0.001);
  in.peer_position_m = DofVector::Constant(dof, 0.002);
  in.peer_velocity_m_per_s = DofVector::Zero(dof);
  in.peer_force_N = DofVector::Zero(dof);
  in.peer_valid = true;
  double x = 0.0;
  for (auto _ : state) {
    x += 1e-7;
    in.position_m[0] = x;
    auto out = law.Step(in, 0.001);
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(BM_LawStep)->Arg(1)->Arg(6);

void BM_PlantUpdate(benchmark::State& state) {
  const bool wall = state.range(0) != 0;
  auto config = device::LoopbackPlantConfig::PaperSlave();
  if (wall) {
    config.environment.kind = device::SimulatedEnvironmentConfig::Kind::kWall;
    config.environment.position_m = -1.0;  // always in contact: the sub-stepped path
    config.environment.stiffness_N_per_m = 1000.0;
    config.initial_position_m = DofVector::Constant(1, -0.99);
  }
  device::LoopbackPlant plant(config);
  device::Reading reading;
  const device::Command command = device::Command::Force(DofVector::Constant(1, 0.5));
  for (auto _ : state) {
    plant.Read(reading);
    plant.Write(command);
    plant.Update(0.001);
    benchmark::DoNotOptimize(reading);
  }
}
BENCHMARK(BM_PlantUpdate)->Arg(0)->Arg(1);

}  // namespace
}  // namespace teleop

BENCHMARK_MAIN();
