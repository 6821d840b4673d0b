#pragma once

#include "device/cobot/planar.hpp"

namespace teleop::device::cobot {

/// The unicycle cobot of Colgate et al. §2 (Fig. 2): one steerable wheel rolling on the floor under a handle. The
/// wheel rolls without lateral slip (or with the optional slip model), so the cart moves along its heading only; a
/// steering motor turns the wheel about its vertical axis through the contact point, which is why it can never push
/// the operator in the plane.
///
/// Rolling:  m·u̇ = F∥ − c·u − F_brake                         (u: wheel speed along the heading, m/s)
/// Steering: J·ω̇ = Γ − b·ω,  ψ̇ = ω                            (ψ: heading, ω: steering velocity)
/// Closing a proportional steering-velocity loop Γ = K₂(ω_c − ω) gives eq 3c, dω/dt = (ω_c − ω)/τ with
/// τ = J/(K₂ + b); the paper's τ is that closed-loop time constant.
/// Slip (cornering stiffness C > 0): the wheel slips sideways at v_slip = u_abs·F_net⊥/C, where F_net⊥ = F⊥ − m·u·ω
/// is the lateral load the floor would have to carry without slip (a quasi-static slip-angle model, α = F_net⊥/C).
/// Friction limit (μ > 0): the floor carries at most μ·N across the wheel (N the normal load, m·g by default). When
/// |F_net⊥| exceeds it the wheel breaks traction and slides: m·v̇_slip = F_net⊥ − sign(v_slip)·μ·N (Coulomb, one μ
/// for sticking and sliding), until the slip velocity returns to zero with |F_net⊥| ≤ μ·N. This is the "unless the
/// wheel slips" of §2: a push hard enough goes through a virtual wall.
struct UnicyclePlantConfig {
  double cart_mass_kg = 10.0;                  ///< m: moving mass (cart, wheel assembly, handle).
  double rolling_damping_Ns_per_m = 20.0;      ///< c: rolling resistance, viscous.
  double steering_inertia_kgm2 = 0.002;        ///< J: wheel assembly about the steering axis, reflected.
  double steering_damping_Nms_per_rad = 0.0;   ///< b: steering bearing and motor friction, viscous.
  double max_steering_torque_Nm = 2.0;         ///< The steering motor's torque limit.
  double cornering_stiffness_N_per_rad = 0.0;  ///< C: 0 = ideal rolling without lateral slip.
  double brake_max_force_N = 0.0;              ///< Wheel brake (a particle brake, as on the prototype); 0 = none.
  double friction_coefficient = 0.0;           ///< μ of the wheel on the floor; 0 = no traction limit.
  double normal_load_N = 0.0;                  ///< N, the wheel's load on the floor; 0 = cart_mass_kg·g.
};

inline constexpr double kGravity_m_per_s2 = 9.80665;
/// μ·N, the largest lateral force the floor carries (infinity when μ = 0).
[[nodiscard]] double TractionLimit_N(const UnicyclePlantConfig& config) noexcept;

struct UnicyclePlantState {
  Vec2 position_m = Vec2::Zero();        ///< Wheel contact point (m, world).
  double heading_rad = 0.0;              ///< ψ: rolling direction from the world x axis.
  double speed_m_per_s = 0.0;            ///< u: along the heading (negative when pulled backwards).
  double steering_rate_rad_per_s = 0.0;  ///< ω.
  double wheel_travel_m = 0.0;  ///< Integrated rolled distance (the wheel encoder sees it divided by the radius).
  double slip_velocity_m_per_s = 0.0;  ///< Lateral slip, along the left normal of the heading.
  bool sliding = false;                ///< Traction broken (friction limit): the floor carries μ·N only.
};

struct UnicyclePlantInput {
  Vec2 handle_force_N = Vec2::Zero();  ///< Operator force on the handle (N, world).
  double steering_torque_Nm = 0.0;     ///< Γ, clamped to the motor's limit.
  double brake_command = 0.0;          ///< 0..1 of brake_max_force_N.
};

/// Throws teleop::Error naming the first bad field.
void Validate(const UnicyclePlantConfig& config);

/// One semi-implicit Euler step of `period_s`. Real-time safe. Non-finite inputs are
/// treated as zero (the caller counts them); the state stays finite.
void Step(const UnicyclePlantConfig& config, const UnicyclePlantInput& input, double period_s,
          UnicyclePlantState& state) noexcept;

/// The lateral force the floor carries on the wheel (N, along the left normal) in the last step's conditions.
[[nodiscard]] double FloorLateralForce_N(const UnicyclePlantConfig& config, const UnicyclePlantState& state,
                                         const Vec2& handle_force_N) noexcept;

}  // namespace teleop::device::cobot
