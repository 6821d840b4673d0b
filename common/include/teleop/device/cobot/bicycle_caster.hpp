#pragma once

#include <array>
#include <cstdint>

#include "teleop/device/cobot/bicycle_plant.hpp"

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
struct BicycleCasterConfig {
  double virtual_mass_kg = 12.0;
  double virtual_inertia_kgm2 = 0.4;
  double speed_floor_m_per_s = 0.02;
  double k2_Nms_per_rad = 0.1;
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
