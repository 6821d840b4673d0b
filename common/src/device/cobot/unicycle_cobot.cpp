#include "device/cobot/unicycle_cobot.hpp"

#include <cmath>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device::cobot {

double SteeringTimeConstant_s(const UnicyclePlantConfig& plant, double k2_Nms_per_rad) noexcept {
  return plant.steering_inertia_kgm2 / (k2_Nms_per_rad + plant.steering_damping_Nms_per_rad);
}

double SteeringGainFor(const UnicyclePlantConfig& plant, double tau_s) {
  if (!std::isfinite(tau_s) || tau_s <= 0.0) {
    throw Error("cobot: steering time constant must be > 0 s (got " + std::to_string(tau_s) + ")");
  }
  const double k2 = plant.steering_inertia_kgm2 / tau_s - plant.steering_damping_Nms_per_rad;
  if (!(k2 > 0.0)) {
    throw Error("cobot: a steering time constant of " + std::to_string(tau_s) +
                " s is slower than the open steering loop J/b; no positive K2 reaches it");
  }
  return k2;
}

UnicycleCobotConfig UnicycleCobotConfig::Prototype(double tau_s) {
  UnicycleCobotConfig c;
  c.plant.cart_mass_kg = 10.0;
  c.plant.rolling_damping_Ns_per_m = 20.0;
  c.plant.steering_inertia_kgm2 = 0.002;
  c.plant.steering_damping_Nms_per_rad = 0.004;
  c.plant.max_steering_torque_Nm = 2.0;
  c.plant.cornering_stiffness_N_per_rad = 500.0;
  const double k2 = SteeringGainFor(c.plant, tau_s);
  c.controller.caster.k1_per_kg = 0.1;
  c.controller.caster.k2_Nms_per_rad = k2;
  c.controller.caster.speed_floor_m_per_s = 0.02;
  c.controller.caster.friction_compensation_Nms_per_rad = c.plant.steering_damping_Nms_per_rad;
  c.controller.tracker.lookahead_m = 0.05;
  c.controller.tracker.k2_Nms_per_rad = k2;
  c.controller.overlay_enabled = true;
  c.controller.overlay_min_radius_m = 0.1;
  return c;
}

namespace {
UnicycleCobotConfig Prepared(UnicycleCobotConfig c) {
  Validate(c.plant);
  Validate(c.sensors);
  if (c.derive_time_constant) {
    c.controller.steering_time_constant_s = SteeringTimeConstant_s(c.plant, c.controller.tracker.k2_Nms_per_rad);
  }
  Validate(c.controller);
  return c;
}
}  // namespace

UnicycleCobot::UnicycleCobot(const UnicycleCobotConfig& config, const Constraint& wall,
                             const UnicyclePlantState& initial)
    : config_(Prepared(config)),
      controller_(config_.controller, wall),
      state_(initial),
      speed_estimator_(config_.speed_filter),
      rate_estimator_(config_.steering_rate_filter) {
  const CobotMeasurement m =
      Measure(config_.sensors, state_.position_m, state_.heading_rad, state_.wheel_travel_m, Vec2::Zero());
  speed_estimator_.Reset(m.wheel_angle_rad, state_.speed_m_per_s / config_.sensors.wheel_radius_m);
  rate_estimator_.Reset(m.steering_angle_rad, state_.steering_rate_rad_per_s);
}

CobotSample UnicycleCobot::Step(const Vec2& handle_force_N, double period_s) noexcept {
  const CobotMeasurement m =
      Measure(config_.sensors, state_.position_m, state_.heading_rad, state_.wheel_travel_m, handle_force_N);
  WallControllerInput in;
  in.position_m = m.position_m;
  in.steering_angle_rad = m.steering_angle_rad;
  in.speed_m_per_s = speed_estimator_.Step(m.wheel_angle_rad, period_s) * config_.sensors.wheel_radius_m;
  in.steering_rate_rad_per_s = rate_estimator_.Step(m.steering_angle_rad, period_s);
  in.handle_force_N = m.handle_force_N;

  CobotSample sample;
  sample.control = controller_.Step(in, period_s);
  UnicyclePlantInput plant_in;
  plant_in.handle_force_N = handle_force_N;
  if (locked_) {
    plant_in.steering_torque_Nm = -config_.controller.tracker.k2_Nms_per_rad * in.steering_rate_rad_per_s;
    plant_in.brake_command = 1.0;
  } else {
    plant_in.steering_torque_Nm = sample.control.steering_torque_Nm;
    plant_in.brake_command = sample.control.brake_command;
  }
  cobot::Step(config_.plant, plant_in, period_s, state_);

  sample.position_m = state_.position_m;
  sample.heading_rad = state_.heading_rad;
  sample.speed_m_per_s = state_.speed_m_per_s;
  sample.steering_rate_rad_per_s = state_.steering_rate_rad_per_s;
  sample.handle_force_N = handle_force_N;
  sample.lateral_force_N = handle_force_N.dot(LeftNormal(UnitAt(state_.heading_rad)));
  sample.lateral_acceleration_m_per_s2 = state_.speed_m_per_s * state_.steering_rate_rad_per_s;
  sample.steering_torque_Nm = plant_in.steering_torque_Nm;
  return sample;
}

}  // namespace teleop::device::cobot
