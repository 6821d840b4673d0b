#pragma once

namespace teleop::device::cobot {

/// The virtual caster of Colgate et al. §3, eq 2:
///   Γ = K₂·( K₁·F⊥ / (sign(u)·max(|u|, ε)) − ω )  [+ b̂·ω_c, optional friction feed-forward].
/// The paper writes Γ = K₁F⊥/(sign(u)max(|u|,ε)) − K₂ω with K₁ "replacing 1/M in eq 1"; that reading holds when the
/// torque is measured in units of the steering-velocity loop, which is how this law is written: K₁ = 1/M is the
/// inverse virtual mass (1/kg) and K₂ the steering-velocity gain (N·m·s/rad). In steady turning the wheel then
/// steers at ω = K₁F⊥/u, eq 1, and the operator feels a lateral mass 1/K₁ for |u| ≥ ε; below ε the steering rate
/// is capped at K₁F⊥/ε and the apparent lateral mass grows as ε/(K₁|u|) (the zero-speed singularity of eq 1).
struct VirtualCasterConfig {
  double k1_per_kg = 0.1;       ///< K₁ = 1/M_virtual.
  double k2_Nms_per_rad = 0.1;  ///< K₂: steering-velocity gain; τ = J/(K₂ + b) is the steering time constant.
  double speed_floor_m_per_s = 0.02;  ///< ε: of the order of the speed resolution.
  /// b̂: feed-forward b̂·ω_c for the steering bearing's viscous friction, so the steady rate is ω_c (0 = none).
  double friction_compensation_Nms_per_rad = 0.0;
};

struct CasterOutput {
  double steering_torque_Nm = 0.0;
  double commanded_rate_rad_per_s = 0.0;  ///< K₁F⊥/(sign(u)max(|u|,ε)).
  double lateral_force_N = 0.0;           ///< F⊥: measured force along the wheel's left normal.
};

/// Throws teleop::Error naming the first bad field.
void Validate(const VirtualCasterConfig& config);

/// Eq 2. `force_N_x/y` the measured handle force (world), `steering_angle_rad` the wheel heading, `speed_m_per_s` u
/// and `steering_rate_rad_per_s` ω as estimated. Real-time safe; pure.
[[nodiscard]] CasterOutput VirtualCasterStep(const VirtualCasterConfig& config, double force_x_N, double force_y_N,
                                             double steering_angle_rad, double speed_m_per_s,
                                             double steering_rate_rad_per_s) noexcept;

}  // namespace teleop::device::cobot
