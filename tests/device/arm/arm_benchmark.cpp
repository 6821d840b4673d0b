// One cycle of a 7-joint arm side's compute (docs/arms.md): ArmModel::Update (FK, J_BT, M_q, C_qv, G_q) and the
// torque law (J_vᵀF, gravity, Coriolis, orientation hold, null-space posture with its refinement, soft limits, clamp),
// the same calls ArmDevice::Read and Write make. Prints the per-cycle p50 and p99 (µs) over the iterations as
// counters beside Google Benchmark's mean:  build/bin/arm_benchmark  (or --benchmark_min_time=2).

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <random>
#include <vector>

#include "arm_chain.hpp"
#include "arm_model.hpp"
#include "arm_torque.hpp"

namespace teleop::device::arm {
namespace {

void BM_SevenJointArmCycle(benchmark::State& state) {
  ArmChainSpec spec;
  spec.urdf_file = std::string(TELEOP_ROBOTS_DIR) + "/arm_7dof.urdf";
  spec.base_link = "base";
  spec.tool_link = "tool";
  ArmModel model(BuildArmChain(spec), Eigen::Vector3d(0.0, 0.0, -9.81));
  ArmTorqueConfig config;
  config.hold_orientation = true;
  config.orientation_stiffness_Nm_per_rad = 20.0;
  config.posture_stiffness_Nm_per_rad = 10.0;
  config.posture_damping_Nms_per_rad = 1.0;
  config.limit_stiffness_Nm_per_rad = 50.0;
  config.coriolis_compensation = true;
  ArmTorque law(model, config);
  std::mt19937 rng(1);
  std::vector<JointVector> qs;
  for (int i = 0; i < 64; ++i) {
    JointVector q(7);
    for (int j = 0; j < 7; ++j) {
      const JointSpec& js = model.arm().joints[static_cast<std::size_t>(j)];
      q[j] = std::uniform_real_distribution<double>(js.lower + 0.3, js.upper - 0.3)(rng);
    }
    qs.push_back(q);
  }
  const JointVector v(JointVector::Constant(7, 0.1));
  const Eigen::Vector3d f(1.0, -2.0, 3.0);
  std::vector<double> samples_us;
  samples_us.reserve(1u << 22);
  std::size_t k = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const bool ok = model.Update(qs[k++ & 63u], v);
    const ArmTorqueTerms& t = law.Step(model, qs[(k - 1) & 63u], v, f, true);
    benchmark::DoNotOptimize(ok);
    benchmark::DoNotOptimize(t.applied_Nm.data());
    const auto stop = std::chrono::steady_clock::now();
    if (samples_us.size() < samples_us.capacity()) {
      samples_us.push_back(std::chrono::duration<double, std::micro>(stop - start).count());
    }
  }
  if (!samples_us.empty()) {
    std::sort(samples_us.begin(), samples_us.end());
    const auto at = [&](double p) {
      return samples_us[static_cast<std::size_t>(p * static_cast<double>(samples_us.size() - 1))];
    };
    state.counters["p50_us"] = at(0.50);
    state.counters["p99_us"] = at(0.99);
    state.counters["max_us"] = samples_us.back();
  }
}
BENCHMARK(BM_SevenJointArmCycle);

}  // namespace
}  // namespace teleop::device::arm

BENCHMARK_MAIN();
