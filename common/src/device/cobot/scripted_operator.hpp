#pragma once

#include "device/cobot/constraint.hpp"
#include "device/cobot/unicycle_plant.hpp"

namespace teleop::device::cobot {

/// Scripted operators for the Colgate et al. scenarios and tests (a human's intent reduced to two loops). Library
/// teleop::device_cobot_sim, not part of the backend.

/// Turning at a fixed lateral acceleration: a PI on the force along the wheel holds the speed, a PI on the force
/// across it holds the lateral acceleration u·ω at the target. The lateral force it ends up applying, over the
/// lateral acceleration, is the apparent lateral mass of the cobot.
struct TurningOperatorConfig {
  double speed_m_per_s = 0.2;
  double lateral_acceleration_m_per_s2 = 0.1;
  double speed_gain_Ns_per_m = 200.0;
  double speed_integral_gain_N_per_m = 500.0;
  double lateral_integral_gain_Ns_per_m = 100.0;  ///< dF⊥/dt per unit of lateral-acceleration error.
  double max_force_N = 100.0;
};

class TurningOperator {
 public:
  explicit TurningOperator(const TurningOperatorConfig& config) : config_(config) {}
  /// Force (N, world) for the next period, from the true plant state.
  [[nodiscard]] Vec2 Step(const UnicyclePlantState& state, double period_s) noexcept;
  double lateral_force_N() const noexcept { return lateral_N_; }

 private:
  TurningOperatorConfig config_;
  double speed_integral_N_ = 0.0;
  double lateral_N_ = 0.0;
};

/// Pushing against a guide curve: the force points along the guide's tangent (the way the cobot is moving) tilted
/// by push_angle_rad into its forbidden side; its size is a PI on the cart speed. Before contact this drives the
/// cart into the wall at the push angle (a wall strike, Figs 4, 7, 9); on the wall it presses while sliding along.
struct PushingOperatorConfig {
  double speed_m_per_s = 0.2;
  double push_angle_rad = 0.5;
  double speed_gain_Ns_per_m = 200.0;
  double speed_integral_gain_N_per_m = 500.0;
  double max_force_N = 100.0;
  double min_force_N = 0.5;  ///< Always at least this much along the push direction.
};

class PushingOperator {
 public:
  PushingOperator(const PushingOperatorConfig& config, const Constraint& guide) : config_(config), guide_(guide) {}
  [[nodiscard]] Vec2 Step(const UnicyclePlantState& state, double period_s) noexcept;
  /// The push direction (unit, world) for a cart at `position_m` moving along `motion`.
  [[nodiscard]] Vec2 Direction(const Vec2& position_m, const Vec2& motion) const noexcept;
  void set_push_angle_rad(double angle_rad) noexcept { config_.push_angle_rad = angle_rad; }

 private:
  PushingOperatorConfig config_;
  Constraint guide_;
  double speed_integral_N_ = 0.0;
};

}  // namespace teleop::device::cobot
