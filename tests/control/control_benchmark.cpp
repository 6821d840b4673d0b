// Cost of one control cycle's pieces: law Step (1..12 DOF), plant Update (free and in wall contact), and the compute of
// a whole cycle of one side versus DOF (BM_CycleCompute: plant read, law and fixture, command, plant write and update,
// encode the sample, decode the peer's): the DOF sweep of docs/performance.md fits a line through these. Prints
// numbers; asserts nothing.

#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>

#include "teleop/control/three_channel_law.hpp"
#include "teleop/device/law_command.hpp"
#include "teleop/device/loopback.hpp"
#include "teleop/proto/codec.hpp"

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
BENCHMARK(BM_LawStep)->Arg(1)->Arg(2)->Arg(3)->Arg(6)->Arg(7)->Arg(12);

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

// One side's cycle without its system calls, at `dof` DOF: what grows with DOF inside the cycle. Three fixture planes
// (a box corner), the loopback plant with an operator, the sample encoded and the peer's decoded.
void BM_CycleCompute(benchmark::State& state) {
  const int dof = static_cast<int>(state.range(0));
  auto config = control::ThreeChannelLaw::ZeroGains(Role::kSlave, dof);
  config.kp_N_per_m.setConstant(600.0);
  config.kd_Ns_per_m.setConstant(2.0);
  config.max_force_N = 5.0;
  config.velocity_filter_hz = 200.0;
  config.fixture.dof = dof;
  config.fixture.stiffness_N_per_m = 2000.0;
  config.fixture.plane_count = dof < 3 ? dof : 3;
  for (int i = 0; i < config.fixture.plane_count; ++i) {
    config.fixture.planes[static_cast<std::size_t>(i)].normal = DofVector::Unit(dof, i);
    config.fixture.planes[static_cast<std::size_t>(i)].offset_m = 0.001;
  }
  control::ThreeChannelLaw law(config);
  auto plant_config = device::LoopbackPlantConfig::PaperSlave(dof);
  device::LoopbackPlant plant(plant_config);
  device::Reading reading;
  device::Command command = device::Command::Force(DofVector::Zero(dof));
  proto::SampleMessage peer{};
  peer.sender = proto::SenderRole::kMaster;
  peer.dof = static_cast<std::uint8_t>(dof);
  for (int i = 0; i < dof; ++i) peer.position_m[static_cast<std::size_t>(i)] = 0.002;
  std::array<std::uint8_t, proto::kMaxEncodedSampleBytes> peer_bytes{};
  const std::size_t peer_size = proto::EncodeSample(peer, peer_bytes);
  std::array<std::uint8_t, proto::kMaxEncodedSampleBytes> out_bytes{};
  proto::SampleMessage decoded{};
  proto::SampleMessage mine{};
  mine.sender = proto::SenderRole::kSlave;
  mine.dof = static_cast<std::uint8_t>(dof);
  control::ThreeChannelLaw::Input in;
  in.peer_valid = true;
  std::uint32_t sequence = 0;
  for (auto _ : state) {
    plant.Read(reading);
    if (proto::DecodeSample(std::span<const std::uint8_t>(peer_bytes.data(), peer_size), decoded) ==
        proto::DecodeStatus::kOk) {
      in.peer_position_m = DofVector::Map(decoded.position_m.data(), dof);
      in.peer_velocity_m_per_s = DofVector::Map(decoded.velocity_m_per_s.data(), dof);
      in.peer_force_N = DofVector::Map(decoded.force_N.data(), dof);
    }
    in.position_m = reading.position_m;
    const auto out = law.Step(in, 0.001);
    device::FillCommand(out, law.fixture(), in.position_m, command);
    plant.Write(command);
    plant.Update(0.001);
    mine.sequence = ++sequence;
    for (int i = 0; i < dof; ++i) {
      mine.position_m[static_cast<std::size_t>(i)] = reading.position_m[i];
      mine.force_N[static_cast<std::size_t>(i)] = out.command_N[i];
    }
    benchmark::DoNotOptimize(proto::EncodeSample(mine, out_bytes));
    benchmark::ClobberMemory();
  }
  state.counters["dof"] = dof;
}
BENCHMARK(BM_CycleCompute)->Arg(1)->Arg(2)->Arg(3)->Arg(6)->Arg(7)->Arg(12);

}  // namespace
}  // namespace teleop

BENCHMARK_MAIN();
