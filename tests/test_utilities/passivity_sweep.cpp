#include "test_utilities/passivity_sweep.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "test_utilities/closed_loop.hpp"

namespace teleop::test {
namespace {

constexpr double kDivergedPosition_m = 1.0;

struct Window {
  double min = std::numeric_limits<double>::infinity();
  double max = -std::numeric_limits<double>::infinity();
  void Add(double v) {
    min = std::min(min, v);
    max = std::max(max, v);
  }
  double PeakToPeak() const { return max >= min ? max - min : 0.0; }
};

}  // namespace

bool PassivityDelayResult::unstable() const noexcept {
  return diverged || (late_amplitude_m > 2.0 * early_amplitude_m && late_amplitude_m > 0.5e-3);
}

PassivityDelayResult RunPassivityDelay(const PassivityDelaySetup& setup, int delay_cycles,
                                       control::PassivityMode mode) {
  OneDofSetup s;
  s.rate_hz = setup.rate_hz;
  s.delay_cycles = delay_cycles;
  s.jitter_cycles = setup.jitter_cycles;
  s.loss = setup.loss;
  s.seed = setup.seed;
  s.kpm_N_per_m = s.kps_N_per_m = setup.kp_N_per_m;
  s.kdm_Ns_per_m = s.kds_Ns_per_m = setup.kd_Ns_per_m;
  s.max_force_N = setup.max_force_N;
  ClosedLoopConfig config = MakeOneDofConfig(s);
  device::SimulatedOperatorConfig& human = config.master_plant.human;  // a pure force source on the master
  human.enabled = true;
  human.mass_kg = setup.hand_mass_kg;
  human.damping_Ns_per_m = setup.hand_damping_Ns_per_m;
  human.stiffness_N_per_m = setup.hand_stiffness_N_per_m;
  human.segment_count = 1;
  human.segments[0] = {};
  human.segments[0].kind = device::OperatorSegment::Kind::kSine;
  human.segments[0].amplitude_N = setup.operator_amplitude_N;
  human.segments[0].frequency_hz = setup.operator_frequency_hz;
  config.slave_plant.initial_position_m = DofVector::Constant(1, setup.initial_offset_m);
  for (control::PassivityController::Config* pc : {&config.master_passivity, &config.slave_passivity}) {
    pc->mode = mode;
    pc->max_damping_Ns_per_m = DofVector::Constant(1, setup.max_damping_Ns_per_m);
    pc->max_force_N = setup.max_force_N;
  }
  ClosedLoop loop(config);

  PassivityDelayResult r;
  r.delay_cycles = delay_cycles;
  r.mode = mode;
  const double late_from_s = setup.duration_s - 0.5;
  Window early;
  Window late;
  Window late_master;
  double late_sq = 0.0;
  int late_count = 0;
  const auto cycles = static_cast<std::int64_t>(std::llround(setup.duration_s * setup.rate_hz));
  for (std::int64_t k = 0; k < cycles; ++k) {
    const ClosedLoopSample& x = loop.Step();
    const double xm = x.master_position_m[0];
    const double xs = x.slave_position_m[0];
    if (!std::isfinite(xm) || !std::isfinite(xs) || std::fabs(xm) > kDivergedPosition_m ||
        std::fabs(xs) > kDivergedPosition_m) {
      r.diverged = true;
      break;
    }
    r.max_abs_position_m = std::max({r.max_abs_position_m, std::fabs(xm), std::fabs(xs)});
    const double e = xs - xm;
    if (x.time_s >= 0.5 && x.time_s < 1.0) early.Add(e);
    if (x.time_s >= late_from_s) {
      late.Add(e);
      late_master.Add(xm);
      late_sq += e * e;
      ++late_count;
    }
    r.min_network_energy_J = std::min(r.min_network_energy_J, x.network_energy_J);
    r.final_network_energy_J = x.network_energy_J;
    if (x.master_pc_acted || x.slave_pc_acted) ++r.acting_cycles;
  }
  r.early_amplitude_m = early.PeakToPeak();
  r.late_amplitude_m = r.diverged ? std::numeric_limits<double>::infinity() : late.PeakToPeak();
  r.late_tracking_rms_m = late_count > 0 ? std::sqrt(late_sq / late_count) : 0.0;
  r.late_master_pp_m = late_master.PeakToPeak();
  r.growth = r.early_amplitude_m > 0.0 ? r.late_amplitude_m / r.early_amplitude_m : 0.0;
  r.dissipated_J = loop.master_passivity().total_dissipated_J() + loop.slave_passivity().total_dissipated_J();
  return r;
}

WallPressResult RunWallPress(const PassivityDelaySetup& setup, int delay_cycles, control::PassivityMode mode,
                             double wall_N_per_m, double press_force_N) {
  OneDofSetup s;
  s.rate_hz = setup.rate_hz;
  s.delay_cycles = delay_cycles;
  s.jitter_cycles = setup.jitter_cycles;
  s.loss = setup.loss;
  s.seed = setup.seed;
  s.kpm_N_per_m = s.kps_N_per_m = setup.kp_N_per_m;
  s.kdm_Ns_per_m = s.kds_Ns_per_m = setup.kd_Ns_per_m;
  s.max_force_N = setup.max_force_N;
  s.slave_fixture_N_per_m = wall_N_per_m;
  s.operator_force_N = press_force_N;
  s.operator_ramp_s = setup.duration_s * 2.0 / 3.0;
  s.human_mass_kg = setup.hand_mass_kg;
  s.human_damping_Ns_per_m = setup.hand_damping_Ns_per_m;
  s.human_stiffness_N_per_m = setup.hand_stiffness_N_per_m;
  ClosedLoopConfig config = MakeOneDofConfig(s);
  for (control::PassivityController::Config* pc : {&config.master_passivity, &config.slave_passivity}) {
    pc->mode = mode;
    pc->max_damping_Ns_per_m = DofVector::Constant(1, setup.max_damping_Ns_per_m);
    pc->max_force_N = setup.max_force_N;
  }
  ClosedLoop loop(config);

  WallPressResult r;
  r.delay_cycles = delay_cycles;
  r.mode = mode;
  r.ideal_stiffness_N_per_m = setup.kp_N_per_m * wall_N_per_m / (setup.kp_N_per_m + wall_N_per_m);
  const double ramp_from_s = s.operator_ramp_s / 2.0;
  double n = 0.0;
  double sx = 0.0;
  double sf = 0.0;
  double sxx = 0.0;
  double sxf = 0.0;
  double hold_first = 0.0;
  double hold_last = 0.0;
  double hold_sum = 0.0;
  double slave_sum = 0.0;
  double slave_sq = 0.0;
  int hold_count = 0;
  const auto cycles = static_cast<std::int64_t>(std::llround(setup.duration_s * setup.rate_hz));
  for (std::int64_t k = 0; k < cycles; ++k) {
    const ClosedLoopSample& x = loop.Step();
    const double xm = x.master_position_m[0];
    if (!std::isfinite(xm) || std::fabs(xm) > kDivergedPosition_m) {
      r.diverged = true;
      break;
    }
    const double f = x.operator_force_N[0];
    if (x.time_s >= ramp_from_s && x.time_s < s.operator_ramp_s) {
      n += 1.0;
      sx += xm;
      sf += f;
      sxx += xm * xm;
      sxf += xm * f;
    } else if (x.time_s >= s.operator_ramp_s) {
      if (hold_count == 0) hold_first = xm;
      hold_last = xm;
      hold_sum += xm;
      slave_sum += x.slave_position_m[0];
      slave_sq += x.slave_position_m[0] * x.slave_position_m[0];
      ++hold_count;
    }
    r.min_network_energy_J = std::min(r.min_network_energy_J, x.network_energy_J);
  }
  const double var = n * sxx - sx * sx;
  r.perceived_stiffness_N_per_m = var > 0.0 ? (n * sxf - sx * sf) / var : 0.0;
  if (hold_count > 0) {
    r.hold_master_m = hold_sum / hold_count;
    r.hold_drift_m = hold_last - hold_first;
    const double mean = slave_sum / hold_count;
    r.hold_slave_std_m = std::sqrt(std::max(0.0, slave_sq / hold_count - mean * mean));
  }
  return r;
}

std::vector<PassivityDelayResult> SweepPassivityDelay(const PassivityDelaySetup& setup, int first_delay, int last_delay,
                                                      const std::vector<control::PassivityMode>& modes) {
  std::vector<PassivityDelayResult> results;
  for (int d = first_delay; d <= last_delay; ++d) {
    for (const control::PassivityMode mode : modes) results.push_back(RunPassivityDelay(setup, d, mode));
  }
  return results;
}

int FirstUnstableDelay(const std::vector<PassivityDelayResult>& results, control::PassivityMode mode) {
  int first = -1;
  for (const PassivityDelayResult& r : results) {
    if (r.mode == mode && r.unstable() && (first < 0 || r.delay_cycles < first)) first = r.delay_cycles;
  }
  return first;
}

}  // namespace teleop::test
