#pragma once

#include <cstdint>
#include <vector>

#include "teleop/control/passivity_controller.hpp"

namespace teleop::test {

/// The delay demonstration of docs/stability.md ("Time-domain passivity"): the paper's 1-DOF master and slave
/// (§4.1 masses and damping), coupled by a PD law (K_p, K_d on both sides), lock-step at rate_hz with a delay of
/// `delay_cycles` samples in each direction. The operator drives the master with a force F_h*(t) = A·sin(2πft)
/// and no hand impedance (m_h = b_h = k_h = 0: a pure force source, the least stabilising operator); the slave starts
/// `initial_offset_m` away from the master. A stable pair tracks with a steady error; an unstable one oscillates
/// with a growing amplitude.
struct PassivityDelaySetup {
  double rate_hz = 1000.0;
  double kp_N_per_m = 300.0;
  double kd_Ns_per_m = 1.0;
  double max_damping_Ns_per_m = 20.0;  ///< The passivity controller's bound on α.
  double max_force_N = 0.0;            ///< The laws' saturation (0 = none).
  double initial_offset_m = 0.002;
  double operator_amplitude_N = 0.2;
  double operator_frequency_hz = 1.0;
  double duration_s = 4.0;
  /// The operator's hand (eq. 2) on the master; all 0 (the default): a pure force source.
  double hand_mass_kg = 0.0;
  double hand_damping_Ns_per_m = 0.0;
  double hand_stiffness_N_per_m = 0.0;
  /// The link beyond its fixed delay (ClosedLoopConfig): jitter in samples, loss probability, seed.
  int jitter_cycles = 0;
  double loss = 0.0;
  std::uint32_t seed = 1;
};

/// What one run did. Amplitudes are the peak-to-peak of the tracking error x_s - x_m in a window.
struct PassivityDelayResult {
  int delay_cycles = 0;
  control::PassivityMode mode = control::PassivityMode::kOff;
  double early_amplitude_m = 0.0;  ///< Window [0.5, 1.0) s.
  double late_amplitude_m = 0.0;   ///< The last 0.5 s.
  double growth = 0.0;             ///< late / early amplitude (> 1: the oscillation grows).
  double max_abs_position_m = 0.0;
  double late_tracking_rms_m = 0.0;   ///< RMS of x_s - x_m over the last 0.5 s.
  double late_master_pp_m = 0.0;      ///< Peak-to-peak master position over the last 0.5 s (how far it moved).
  double min_network_energy_J = 0.0;  ///< min over the run of the energy the laws + link absorbed (< 0: generated).
  double final_network_energy_J = 0.0;
  double dissipated_J = 0.0;        ///< By both passivity controllers.
  std::uint64_t acting_cycles = 0;  ///< Cycles in which either controller acted.
  bool diverged = false;            ///< Position beyond 1 m or not finite: stopped early.
  /// Unstable: the oscillation grew (late amplitude > 2 × early and > 0.5 mm) or the run diverged.
  bool unstable() const noexcept;
};

PassivityDelayResult RunPassivityDelay(const PassivityDelaySetup& setup, int delay_cycles, control::PassivityMode mode);

/// Transparency (issue 32.4): the same pair with the operator pressing the slave into a wall (a slave fixture of
/// `wall_N_per_m` at X = 0, both devices starting at 0): the operator, a pure force source, ramps F_h from 0 to
/// `press_force_N` over the run's first 2/3 and holds it. The perceived stiffness is the slope of the force at the
/// handle (the master's force sensor) against the master's position over the ramp's second half (least squares),
/// what the operator's hand feels; a transparent pair renders the wall in series with the coupling spring,
/// K_p·K_w / (K_p + K_w).
struct WallPressResult {
  int delay_cycles = 0;
  control::PassivityMode mode = control::PassivityMode::kOff;
  double perceived_stiffness_N_per_m = 0.0;
  double ideal_stiffness_N_per_m = 0.0;  ///< K_p·K_w / (K_p + K_w).
  double hold_master_m = 0.0;            ///< Mean master position while the force is held (the last third).
  double hold_drift_m = 0.0;             ///< How far the master moved while the force was held (last - first).
  double hold_slave_std_m = 0.0;         ///< The slave's position ripple while held (RMS about its mean).
  double min_network_energy_J = 0.0;
  bool diverged = false;
};
WallPressResult RunWallPress(const PassivityDelaySetup& setup, int delay_cycles, control::PassivityMode mode,
                             double wall_N_per_m, double press_force_N);

/// Runs every delay in [first, last] with every mode given.
std::vector<PassivityDelayResult> SweepPassivityDelay(const PassivityDelaySetup& setup, int first_delay, int last_delay,
                                                      const std::vector<control::PassivityMode>& modes);

/// The smallest delay of `results` at which the run in `mode` is unstable; -1 if none.
int FirstUnstableDelay(const std::vector<PassivityDelayResult>& results, control::PassivityMode mode);

}  // namespace teleop::test
