#pragma once

#include <cstdint>

#include "device/cobot/constraint_tracker.hpp"

namespace teleop::device::cobot {

/// The stability condition of constraint tracking, Colgate et al. eq 10: linearizing eqs 5a–c under the law
/// κ̃_c = a·p + b·θ gives the characteristic polynomial (eq 9, with its λ² coefficient corrected to 1/(uτ))
///   uτ·λ³ + λ² + (uτ/ρ² + b)·λ + (1/ρ² + a) = 0,
/// whose Routh–Hurwitz condition is uτ < b/a. With eq 7's gains b/a = ρ·tan φ (eq 10: uτ/ρ < tan φ); with eq 8's,
/// b/a = L (eq 11: uτ < L). Separate gain scales multiply the bound by theta_scale/p_scale.
/// The bound ignores the estimation filters, sampling and torque limits; the cobot-stability scenario measures how
/// far the simulation's boundary lies from it.
[[nodiscard]] double MaxStableSpeed_m_per_s(const ConstraintTrackerConfig& config, double steering_time_constant_s,
                                            double curvature_per_m, double lookahead_m = 0.0) noexcept;

/// The roots' real parts of the linearized cubic above (for tests and the analysis): the largest real part (1/m,
/// per unit arc length); < 0 means stable.
[[nodiscard]] double LinearizedGrowthRate_per_m(double speed_tau_m, double curvature_per_m, double p_gain_per_m2,
                                                double theta_gain_per_m) noexcept;

/// What the controller does when the measured speed approaches the eq 10 bound.
struct StabilityGuardConfig {
  enum class Action : std::uint8_t { kWarn, kLengthenLookahead, kBrake };
  Action action = Action::kWarn;
  double margin = 0.8;  ///< Act when |u| > margin · u_max.
};

struct StabilityStatus {
  double max_stable_speed_m_per_s = 0.0;  ///< u_max from eq 10 at the current lookahead.
  double speed_tau_m = 0.0;               ///< |u|·τ.
  double lookahead_m = 0.0;               ///< L in use (lengthened when the action says so).
  double brake_command = 0.0;             ///< 0..1 when the action is kBrake.
  bool warning = false;                   ///< |u| > margin·u_max at the configured L.
};

/// Evaluates the guard for the measured speed. Real-time safe.
[[nodiscard]] StabilityStatus EvaluateStability(const StabilityGuardConfig& guard,
                                                const ConstraintTrackerConfig& tracker, double steering_time_constant_s,
                                                double curvature_per_m, double speed_m_per_s) noexcept;

}  // namespace teleop::device::cobot
