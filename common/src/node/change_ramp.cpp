#include "change_ramp.hpp"

#include <algorithm>
#include <cmath>

namespace teleop::node {

namespace {

double Floor_s(double force_step_N, double max_force_rate_N_per_s) noexcept {
  if (!(max_force_rate_N_per_s > 0.0) || !std::isfinite(force_step_N)) return 0.0;
  return force_step_N / max_force_rate_N_per_s;
}

}  // namespace

double StiffnessRampFloor_s(const control::ForbiddenRegionFixture& fixture, const DofVector& position_m,
                            double target_N_per_m, double max_force_rate_N_per_s) noexcept {
  const double now_N_per_m = fixture.config().stiffness_N_per_m;
  if (fixture.config().plane_count == 0 || !std::isfinite(target_N_per_m)) return 0.0;
  control::ForbiddenRegionFixture unit = fixture;  // fixed-size storage: no allocation
  unit.SetStiffness(1.0);
  const DofVector per_stiffness_m = unit.Step(position_m).force_N;  // N per N/m: the penetration along each axis
  if (per_stiffness_m.size() == 0) return 0.0;
  return Floor_s(std::abs(target_N_per_m - now_N_per_m) * per_stiffness_m.cwiseAbs().maxCoeff(),
                 max_force_rate_N_per_s);
}

double GainRampFloor_s(const control::ThreeChannelLaw::Config& now, const DofVector (&target)[4],
                       const GainSignals& signals, double max_force_rate_N_per_s) noexcept {
  const DofVector* from[4] = {&now.kp_N_per_m, &now.kd_Ns_per_m, &now.kv_Ns_per_m, &now.kf};
  const DofVector* signal[4] = {&signals.position_error_m, &signals.velocity_error_m_per_s, &signals.velocity_m_per_s,
                                &signals.peer_force_N};
  double step_N = 0.0;
  for (int i = 0; i < now.dof; ++i) {
    double axis_N = 0.0;
    for (std::size_t g = 0; g < 4; ++g) {
      if (target[g].size() <= i || from[g]->size() <= i || signal[g]->size() <= i) continue;
      axis_N += (target[g][i] - (*from[g])[i]) * (*signal[g])[i];
    }
    step_N = std::max(step_N, std::abs(axis_N));
  }
  return Floor_s(step_N, max_force_rate_N_per_s);
}

}  // namespace teleop::node
