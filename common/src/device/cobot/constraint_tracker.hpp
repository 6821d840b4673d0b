#pragma once

#include <cstdint>

#include "device/cobot/constraint.hpp"

namespace teleop::device::cobot {

/// Constraint tracking, Colgate et al. §4 (after Ollero & Heredia): the wheel's penetration p and out-of-tangency θ
/// (Fig. 5) feed a curvature command on top of the path's own curvature 1/ρ:
///   eq 7:  κ̃_c = cos φ/(ρ²(1 − cos φ))·p + sin φ/(ρ(1 − cos φ))·θ,   φ = L/ρ (lookahead arc angle)
///   eq 8:  κ̃_c = (2/L²)·p + (2/L)·θ                                   (small φ; straight lines always use it)
/// The p and θ gains are scaled separately (§4.2 tunes them independently), an optional integral of p over arc
/// length removes the steady-state error §4.2 reports, and the steering-velocity command is
/// ω_c = |u|·(1/ρ + κ̃_c) turned away from the wall.
struct ConstraintTrackerConfig {
  enum class GainForm : std::uint8_t { kSmallAngle, kCircular };  ///< eq 8, eq 7.
  GainForm gain_form = GainForm::kSmallAngle;
  double lookahead_m = 0.05;           ///< L.
  double p_gain_scale = 1.0;           ///< Multiplies the penetration gain.
  double theta_gain_scale = 1.0;       ///< Multiplies the out-of-tangency gain.
  double integral_gain_per_m3 = 0.0;   ///< κ += k_i·∫p ds (1/m³); 0 = off.
  double integral_limit_m2 = 1e-3;     ///< Anti-windup bound on ∫p ds.
  double max_curvature_per_m = 100.0;  ///< Bound on the curvature command (the tightest turn the wheel may make).
  double k2_Nms_per_rad = 0.1;         ///< Steering-velocity gain: Γ = K₂(ω_c − ω).
  /// b̂: feed-forward b̂·ω_c for the steering friction. 0 reproduces the paper's circle error, which it reduced by
  /// "modestly increasing the wheel's nominal steering velocity command" — what this term does.
  double friction_compensation_Nms_per_rad = 0.0;
};

/// The tracking errors of one sample, in the paper's signs.
struct TrackingErrors {
  double penetration_m = 0.0;  ///< p (> 0 inside the wall).
  double theta_rad = 0.0;      ///< θ: heading of motion from the tangent, > 0 pointing into the wall.
  double away_sign = 1.0;      ///< +1 when turning away from the wall is counter-clockwise (ω > 0), else −1.
};

/// p and θ for a wheel moving along `motion_heading_rad` (the heading, flipped when u < 0).
[[nodiscard]] TrackingErrors ComputeTrackingErrors(const ConstraintSample& sample, double motion_heading_rad) noexcept;

/// The (p, θ) gains (1/m², 1/m) of eq 7 or eq 8 for lookahead `lookahead_m` and path curvature `curvature_per_m`,
/// before the separate scales. Eq 7 falls back to eq 8 when |κ|·L < 1e-3 (ρ ≫ L); φ is capped at 1.4 rad.
struct TrackingGains {
  double p_per_m2 = 0.0;
  double theta_per_m = 0.0;
};
[[nodiscard]] TrackingGains ComputeTrackingGains(ConstraintTrackerConfig::GainForm form, double lookahead_m,
                                                 double curvature_per_m) noexcept;

struct TrackerOutput {
  double steering_torque_Nm = 0.0;
  double commanded_rate_rad_per_s = 0.0;
  double curvature_command_per_m = 0.0;  ///< 1/ρ + κ̃_c (away from the wall).
  TrackingErrors errors{};
};

/// Throws teleop::Error naming the first bad field.
void Validate(const ConstraintTrackerConfig& config);

class ConstraintTracker {
 public:
  explicit ConstraintTracker(const ConstraintTrackerConfig& config = {});
  void Reset() noexcept { integral_m2_ = 0.0; }
  /// One control step. `lookahead_m` overrides the configured L when > 0 (the stability monitor may lengthen it).
  [[nodiscard]] TrackerOutput Step(const ConstraintSample& sample, double steering_angle_rad, double speed_m_per_s,
                                   double steering_rate_rad_per_s, double period_s, double lookahead_m = 0.0) noexcept;
  const ConstraintTrackerConfig& config() const noexcept { return config_; }
  double integral_m2() const noexcept { return integral_m2_; }

 private:
  ConstraintTrackerConfig config_;
  double integral_m2_ = 0.0;
};

}  // namespace teleop::device::cobot
