#pragma once

#include <array>

#include "device/cobot/bicycle_kinematics.hpp"

namespace teleop::device::cobot {

/// The bicycle cobot plate: mass m, inertia I about the plate origin, two steered wheels with first-order steering
/// (J·β̈ = Γ − b·β̇ per wheel, β relative to the plate), viscous rolling resistance per wheel.
/// Each step integrates the operator's wrench and then projects the twist onto the velocities the wheels allow, in
/// the plate's mass metric (the impulse the floor applies; energy never increases). The projection uses the rank
/// of the rolling constraints, so the singular configuration is simulated as what it is: a plate with two degrees of
/// freedom instead of one.
struct BicyclePlantConfig {
  BicycleGeometry geometry{};
  double plate_mass_kg = 12.0;
  double plate_inertia_kgm2 = 0.4;
  double rolling_damping_Ns_per_m = 10.0;  ///< Per wheel, along its rolling direction.
  double steering_inertia_kgm2 = 0.002;
  double steering_damping_Nms_per_rad = 0.0;
  double max_steering_torque_Nm = 2.0;
  double rank_tolerance = 1e-9;  ///< Relative singular value below which a constraint row is dependent.
};

struct BicyclePlantState {
  BicyclePose pose{};
  Twist twist = Twist::Zero();
  std::array<double, 2> steer_rad{0.0, 0.0};  ///< β_i, relative to the plate.
  std::array<double, 2> steer_rate_rad_per_s{0.0, 0.0};
  int constraint_rank = 2;  ///< 1 at the singularity.
};

struct BicyclePlantInput {
  Vec2 handle_force_N = Vec2::Zero();  ///< Operator force at the handle (N, world).
  double handle_moment_Nm = 0.0;       ///< Operator moment about the vertical (N·m).
  std::array<double, 2> steering_torque_Nm{0.0, 0.0};
};

/// Throws teleop::Error naming the first bad field.
void Validate(const BicyclePlantConfig& config);

/// Projects `twist` onto the velocities the wheels allow, in the mass metric; returns the constraints' rank.
int ProjectOntoRolling(const BicyclePlantConfig& config, const BicyclePose& pose, double steer0_rad, double steer1_rad,
                       Twist& twist) noexcept;

/// One step of `period_s`. Real-time safe; non-finite inputs are treated as zero.
void Step(const BicyclePlantConfig& config, const BicyclePlantInput& input, double period_s,
          BicyclePlantState& state) noexcept;

/// Velocity (m/s, world) of wheel i's contact point.
[[nodiscard]] Vec2 WheelVelocity(const BicycleGeometry& g, const BicyclePlantState& s, int wheel) noexcept;

}  // namespace teleop::device::cobot
