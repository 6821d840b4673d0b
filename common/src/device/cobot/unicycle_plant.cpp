#include "device/cobot/unicycle_plant.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::cobot {

namespace {

void RequirePositive(double v, const char* name) {
  if (!std::isfinite(v) || v <= 0.0) {
    throw Error(std::string("cobot plant: ") + name + " must be finite and > 0 (got " + std::to_string(v) + ")");
  }
}
void RequireNonNegative(double v, const char* name) {
  if (!std::isfinite(v) || v < 0.0) {
    throw Error(std::string("cobot plant: ") + name + " must be finite and >= 0 (got " + std::to_string(v) + ")");
  }
}
double FiniteOr0(double v) noexcept { return std::isfinite(v) ? v : 0.0; }

}  // namespace

void Validate(const UnicyclePlantConfig& c) {
  RequirePositive(c.cart_mass_kg, "cart_mass_kg");
  RequireNonNegative(c.rolling_damping_Ns_per_m, "rolling_damping_Ns_per_m");
  RequirePositive(c.steering_inertia_kgm2, "steering_inertia_kgm2");
  RequireNonNegative(c.steering_damping_Nms_per_rad, "steering_damping_Nms_per_rad");
  RequirePositive(c.max_steering_torque_Nm, "max_steering_torque_Nm");
  RequireNonNegative(c.cornering_stiffness_N_per_rad, "cornering_stiffness_N_per_rad");
  RequireNonNegative(c.brake_max_force_N, "brake_max_force_N");
  RequireNonNegative(c.friction_coefficient, "friction_coefficient");
  RequireNonNegative(c.normal_load_N, "normal_load_N");
}

double TractionLimit_N(const UnicyclePlantConfig& c) noexcept {
  if (!(c.friction_coefficient > 0.0)) return std::numeric_limits<double>::infinity();
  const double load = c.normal_load_N > 0.0 ? c.normal_load_N : c.cart_mass_kg * kGravity_m_per_s2;
  return c.friction_coefficient * load;
}

double FloorLateralForce_N(const UnicyclePlantConfig& c, const UnicyclePlantState& s,
                           const Vec2& handle_force_N) noexcept {
  if (s.sliding) {
    return -std::copysign(TractionLimit_N(c), s.slip_velocity_m_per_s);
  }
  const Vec2 normal = LeftNormal(UnitAt(s.heading_rad));
  return c.cart_mass_kg * s.speed_m_per_s * s.steering_rate_rad_per_s - handle_force_N.dot(normal);
}

void Step(const UnicyclePlantConfig& c, const UnicyclePlantInput& in, double dt, UnicyclePlantState& s) noexcept {
  const Vec2 force = in.handle_force_N.allFinite() ? in.handle_force_N : Vec2::Zero();
  const double torque =
      std::clamp(FiniteOr0(in.steering_torque_Nm), -c.max_steering_torque_Nm, c.max_steering_torque_Nm);
  const double brake = std::clamp(FiniteOr0(in.brake_command), 0.0, 1.0) * c.brake_max_force_N;

  const Vec2 heading = UnitAt(s.heading_rad);
  const Vec2 normal = LeftNormal(heading);
  const double f_along = force.dot(heading);

  // Rolling: viscous part implicit, brake as Coulomb friction that cannot reverse the motion.
  double u =
      (s.speed_m_per_s + dt * f_along / c.cart_mass_kg) / (1.0 + dt * c.rolling_damping_Ns_per_m / c.cart_mass_kg);
  const double brake_dv = dt * brake / c.cart_mass_kg;
  u = std::abs(u) <= brake_dv ? 0.0 : u - std::copysign(brake_dv, u);

  // Steering: J·ω̇ = Γ − b·ω, damping implicit.
  const double omega = (s.steering_rate_rad_per_s + dt * torque / c.steering_inertia_kgm2) /
                       (1.0 + dt * c.steering_damping_Nms_per_rad / c.steering_inertia_kgm2);

  // Slip: quasi-static, proportional to the lateral load the floor would carry without it; beyond the traction
  // limit μ·N the wheel slides (Coulomb friction against the slip velocity).
  const double net_lateral_N = force.dot(normal) - c.cart_mass_kg * u * omega;
  const double limit_N = TractionLimit_N(c);
  double slip = 0.0;
  if (!s.sliding && std::abs(net_lateral_N) > limit_N) {
    s.sliding = true;
  }
  if (s.sliding) {
    const double v = s.slip_velocity_m_per_s;
    const double direction = v != 0.0 ? std::copysign(1.0, v) : std::copysign(1.0, net_lateral_N);
    slip = v + dt * (net_lateral_N - direction * limit_N) / c.cart_mass_kg;
    if (slip * direction <= 0.0 && std::abs(net_lateral_N) <= limit_N) {
      s.sliding = false;  // the friction stopped the slide: traction again
      slip = 0.0;
    }
  }
  if (!s.sliding && c.cornering_stiffness_N_per_rad > 0.0) {
    slip = std::abs(u) * net_lateral_N / c.cornering_stiffness_N_per_rad;
  }

  s.speed_m_per_s = u;
  s.steering_rate_rad_per_s = omega;
  s.slip_velocity_m_per_s = slip;
  s.position_m += dt * (u * heading + slip * normal);
  s.heading_rad = WrapAngle(s.heading_rad + dt * omega);
  s.wheel_travel_m += dt * u;
}

}  // namespace teleop::device::cobot
