#pragma once

#include <array>
#include <cstdint>

#include "device/cobot/bicycle_plant.hpp"

namespace teleop::device::cobot {

/// The virtual caster for the bicycle cobot: eq 1 applied to each wheel. The operator's wrench at the handle asks
/// for the acceleration of a free rigid plate of virtual mass M and inertia I; wheel i's contact point would then
/// accelerate at a_i = a + α×r_i − Ω²r_i, and the wheel steers its rolling direction at
/// ω_i = (n_i·a_i)/(sign(u_i)·max(|u_i|, ε)) (u_i its rolling speed), i.e. at β̇_i = ω_i − Ω relative to the plate,
/// through the same steering-velocity loop Γ_i = K₂(β̇_i,c − β̇_i) as the unicycle.
///
/// Singularity (§2): a plate rotation about a point on the line through the wheels asks for both wheels to point
/// across that line, where the constraints coincide. With the guard on, once the singularity measure falls below
/// singularity_threshold the commanded steering rates are projected so they no longer decrease it: the plate turns
/// about a centre just off the line instead of losing its constraint. With the guard off the configuration is
/// reached and reported (the plate then has two degrees of freedom, harmless in free caster motion).
///
/// Angular constraint (§2: the bicycle "can implement x, y, and angular constraint"): with heading_constraint on,
/// the plate's angular acceleration is no longer the operator's moment over the virtual inertia but a critically
/// damped return to heading_target_rad, α = −ω_h²·(θ − θ_c) − 2ω_h·Ω, while the translation stays a free point mass.
/// Both wheels are steered for that plate motion, so the rotation the operator's moment asks for is refused by the
/// floor, as a wall refuses a push. The heading error then decays as e(t) = e₀·(1 + ω_h·t)·e^(−ω_h·t).
/// The virtual mass and inertia are the plate's (CobotBackend sets them): along the wheels the operator feels the
/// plate itself, so any other mass across them would make force and acceleration non-collinear.
struct BicycleCasterConfig {
  double virtual_mass_kg = 12.0;
  double virtual_inertia_kgm2 = 0.4;
  bool heading_constraint = false;
  double heading_target_rad = 0.0;
  double heading_bandwidth_per_s = 5.0;  ///< ω_h (rad/s), > 0; well below 1/τ of the steering loop.
  double speed_floor_m_per_s = 0.02;
  double k2_Nms_per_rad = 0.1;
  /// Feed-forward b̂·β̇_c of the steering friction (as the unicycle's caster): without it the wheels turn at
  /// K₂/(K₂ + b) of the command and the operator feels (K₂ + b)/K₂ times the mass across them.
  double friction_compensation_Nms_per_rad = 0.0;
  /// The plate's rolling resistance per wheel (N·s/m, the plant's): the free plate the operator should feel is the
  /// plate with the drag its wheels really have, so the acceleration asked for along the motion is the one the plate
  /// reaches and the rotation follows the command (without it the missing drag shows up as extra angular damping).
  double rolling_damping_Ns_per_m = 0.0;
  double singularity_threshold = 0.05;
  bool singularity_guard = true;
};

struct BicycleCasterOutput {
  std::array<double, 2> steering_torque_Nm{0.0, 0.0};
  std::array<double, 2> commanded_steer_rate_rad_per_s{0.0, 0.0};
  double singularity_measure = 1.0;
  bool near_singularity = false;  ///< Measure below the threshold.
  bool guard_active = false;      ///< The guard changed the command this cycle.
};

/// Throws teleop::Error naming the first bad field.
void Validate(const BicycleCasterConfig& config);

/// One step from the measured state and handle wrench. Real-time safe; pure.
[[nodiscard]] BicycleCasterOutput BicycleCasterStep(const BicycleCasterConfig& config, const BicycleGeometry& g,
                                                    const BicyclePlantState& measured, const Vec2& handle_force_N,
                                                    double handle_moment_Nm) noexcept;

}  // namespace teleop::device::cobot
