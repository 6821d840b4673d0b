#include "device/cobot/tracking_stability.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

namespace teleop::device::cobot {

double MaxStableSpeed_m_per_s(const ConstraintTrackerConfig& config, double steering_time_constant_s,
                              double curvature_per_m, double lookahead_m) noexcept {
  const double lookahead = lookahead_m > 0.0 ? lookahead_m : config.lookahead_m;
  const TrackingGains g = ComputeTrackingGains(config.gain_form, lookahead, curvature_per_m);
  if (!(steering_time_constant_s > 0.0)) {
    return std::numeric_limits<double>::infinity();
  }
  const double b_over_a = (config.theta_gain_scale * g.theta_per_m) / (config.p_gain_scale * g.p_per_m2);
  return b_over_a / steering_time_constant_s;
}

double LinearizedGrowthRate_per_m(double speed_tau_m, double curvature_per_m, double p_gain_per_m2,
                                  double theta_gain_per_m) noexcept {
  const double k2 = curvature_per_m * curvature_per_m;
  const double c1 = speed_tau_m * k2 + theta_gain_per_m;
  const double c0 = k2 + p_gain_per_m2;
  if (speed_tau_m <= 0.0) {  // λ² + c1·λ + c0 = 0
    const double disc = c1 * c1 - 4.0 * c0;
    return disc >= 0.0 ? (-c1 + std::sqrt(disc)) / 2.0 : -c1 / 2.0;
  }
  // Companion matrix of λ³ + (1/T)λ² + (c1/T)λ + c0/T.
  Eigen::Matrix3d companion = Eigen::Matrix3d::Zero();
  companion(0, 0) = -1.0 / speed_tau_m;
  companion(0, 1) = -c1 / speed_tau_m;
  companion(0, 2) = -c0 / speed_tau_m;
  companion(1, 0) = 1.0;
  companion(2, 1) = 1.0;
  const Eigen::EigenSolver<Eigen::Matrix3d> solver(companion, false);
  return solver.eigenvalues().real().maxCoeff();
}

StabilityStatus EvaluateStability(const StabilityGuardConfig& guard, const ConstraintTrackerConfig& tracker,
                                  double steering_time_constant_s, double curvature_per_m,
                                  double speed_m_per_s) noexcept {
  StabilityStatus s;
  const double speed = std::isfinite(speed_m_per_s) ? std::abs(speed_m_per_s) : 0.0;
  s.speed_tau_m = speed * steering_time_constant_s;
  s.lookahead_m = tracker.lookahead_m;
  s.max_stable_speed_m_per_s = MaxStableSpeed_m_per_s(tracker, steering_time_constant_s, curvature_per_m);
  s.warning = speed > guard.margin * s.max_stable_speed_m_per_s;
  if (!s.warning) {
    return s;
  }
  switch (guard.action) {
    case StabilityGuardConfig::Action::kWarn:
      break;
    case StabilityGuardConfig::Action::kLengthenLookahead: {
      // The bound solved for L: the lookahead that puts |u|·τ at margin of it. Eq 8's gains (and eq 7's on a line):
      // b/a = L (eq 11). Eq 7's on a circle: b/a = ρ·tan(L/ρ) (eq 10), not ∝ L, so L = ρ·atan(b/a / ρ), within the
      // gains' φ ≤ 1.4 rad. The gain scales multiply b/a by theta_scale/p_scale.
      const double wanted_b_over_a = s.speed_tau_m * tracker.p_gain_scale / (guard.margin * tracker.theta_gain_scale);
      const double kappa = std::isfinite(curvature_per_m) ? std::abs(curvature_per_m) : 0.0;
      double wanted_lookahead_m = wanted_b_over_a;
      if (tracker.gain_form == ConstraintTrackerConfig::GainForm::kCircular && kappa > 0.0) {
        wanted_lookahead_m = std::min(std::atan(wanted_b_over_a * kappa), 1.4) / kappa;
      }
      s.lookahead_m = std::max(tracker.lookahead_m, wanted_lookahead_m);
      s.max_stable_speed_m_per_s =
          MaxStableSpeed_m_per_s(tracker, steering_time_constant_s, curvature_per_m, s.lookahead_m);
      break;
    }
    case StabilityGuardConfig::Action::kBrake: {
      const double excess = speed - guard.margin * s.max_stable_speed_m_per_s;
      s.brake_command = std::clamp(excess / (0.1 * s.max_stable_speed_m_per_s), 0.0, 1.0);
      break;
    }
  }
  return s;
}

}  // namespace teleop::device::cobot
