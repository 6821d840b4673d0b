#include "device/hybrid/hybrid_rig.hpp"

#include <Eigen/LU>
#include <cmath>

#include "device/hybrid/brake_friction_solver.hpp"
#include "teleop/error.hpp"

namespace teleop::device::hybrid {

void HybridRigConfig::Validate() const {
  geometry.Validate();
  motor.Validate();
  brake.Validate();
  force_sensor.Validate();
  if (!(std::isfinite(joint_inertia_kgm2) && joint_inertia_kgm2 > 0.0) ||
      !(std::isfinite(handle_mass_kg) && handle_mass_kg >= 0.0) ||
      !(std::isfinite(joint_damping_Nms_per_rad) && joint_damping_Nms_per_rad >= 0.0) ||
      !(std::isfinite(joint_coulomb_Nm) && joint_coulomb_Nm >= 0.0)) {
    throw Error(
        "hybrid rig: joint_inertia_kgm2 must be > 0, handle_mass_kg, joint_damping_Nms_per_rad and joint_coulomb_Nm "
        ">= 0");
  }
  force_sensor_dynamics.Validate();
  encoders.Validate();
  if (substeps < 1 || substeps > 1000) {
    throw Error("hybrid rig: substeps must be 1..1000");
  }
  if (!FiveBar(geometry).InWorkspace(initial_position_m)) {
    throw Error("hybrid rig: initial_position_m is outside the workspace (rectangle and joint limits)");
  }
}

HybridRig::HybridRig(const HybridRigConfig& config)
    : config_(config),
      kinematics_(config.geometry),
      motors_{MotorModel(config.motor), MotorModel(config.motor)},
      brakes_{ParticleBrake(config.brake), ParticleBrake(config.brake)} {
  config_.Validate();
  if (!Reset(config_.initial_position_m)) {
    throw Error("hybrid rig: cannot place the handle at initial_position_m");
  }
}

bool HybridRig::Reset(const Eigen::Vector2d& position_m) noexcept {
  Eigen::Vector2d q;
  if (!kinematics_.InWorkspace(position_m) || !kinematics_.Inverse(position_m, q)) {
    return false;
  }
  for (auto& m : motors_) {
    m.Reset();
  }
  for (auto& b : brakes_) {
    b.Reset();
  }
  state_ = RigState{};
  stuck_[0] = stuck_[1] = true;
  state_.joint_rad = q;
  UpdateCartesian();
  return true;
}

bool HybridRig::Inertia(const Eigen::Vector2d& q, Eigen::Matrix2d& jac, Eigen::Matrix2d& inertia) const noexcept {
  if (!kinematics_.Jacobian(q, jac)) {
    return false;
  }
  inertia = config_.joint_inertia_kgm2 * Eigen::Matrix2d::Identity() + config_.handle_mass_kg * jac.transpose() * jac;
  return true;
}

double HybridRig::KineticEnergyJ() const noexcept {
  Eigen::Matrix2d jac;
  Eigen::Matrix2d m;
  if (!Inertia(state_.joint_rad, jac, m)) {
    return 0.0;
  }
  return 0.5 * state_.joint_velocity_rad_per_s.dot(m * state_.joint_velocity_rad_per_s);
}

void HybridRig::UpdateCartesian() noexcept {
  Eigen::Vector2d p;
  Eigen::Matrix2d jac;
  if (kinematics_.Forward(state_.joint_rad, p) && kinematics_.Jacobian(state_.joint_rad, jac)) {
    state_.position_m = p;
    state_.velocity_m_per_s = jac * state_.joint_velocity_rad_per_s;
    const Eigen::Vector2d tau = state_.motor_joint_Nm + state_.brake_joint_Nm + state_.friction_joint_Nm;
    state_.rendered_force_N = jac.transpose().fullPivLu().solve(tau);
  } else {
    state_.singular = true;
  }
}

void HybridRig::Step(const Eigen::Vector2d& motor_command_joint_Nm, const Eigen::Vector2d& brake_command_shaft_Nm,
                     const Eigen::Vector2d& hand_force_N, double period_s) noexcept {
  if (!(period_s > 0.0) || !std::isfinite(period_s) || state_.singular) {
    return;
  }
  const double h = period_s / config_.substeps;
  const Eigen::Vector2d hand = hand_force_N.allFinite() ? hand_force_N : Eigen::Vector2d::Zero();
  Eigen::Vector2d brake_sum_Nm = Eigen::Vector2d::Zero();
  Eigen::Vector2d friction_sum_Nm = Eigen::Vector2d::Zero();
  for (int s = 0; s < config_.substeps; ++s) {
    Eigen::Matrix2d jac;
    Eigen::Matrix2d m;
    if (!Inertia(state_.joint_rad, jac, m)) {
      state_.singular = true;
      return;
    }
    Eigen::Vector2d tau_motor;
    Eigen::Vector2d capacity;
    Eigen::Vector2d brake_share;  // the brake's part of the friction capacity (the rest: joint Coulomb friction)
    for (int i = 0; i < 2; ++i) {
      tau_motor(i) = motors_[i].Step(motor_command_joint_Nm(i), h);
      const double brake_cap = brakes_[i].Step(brake_command_shaft_Nm(i), h);
      const double total = brake_cap + config_.joint_coulomb_Nm;
      brake_share(i) = total > 0.0 ? brake_cap / total : 0.0;
      capacity(i) = total * (stuck_[i] ? config_.brake.static_ratio : 1.0);  // static above sliding
    }
    const Eigen::Vector2d& qd = state_.joint_velocity_rad_per_s;
    // Velocity-product term m·Jᵀ·(J̇q̇), J̇q̇ by a directional difference of J along q̇.
    Eigen::Vector2d coriolis = Eigen::Vector2d::Zero();
    const double speed = qd.norm();
    if (speed > 1e-9 && config_.handle_mass_kg > 0.0) {
      const double eps = 1e-6 / speed;
      Eigen::Matrix2d jac_ahead;
      if (kinematics_.Jacobian(state_.joint_rad + eps * qd, jac_ahead)) {
        coriolis = config_.handle_mass_kg * jac.transpose() * ((jac_ahead - jac) / eps * qd);
      }
    }
    const Eigen::Vector2d tau = tau_motor + jac.transpose() * hand - config_.joint_damping_Nms_per_rad * qd - coriolis;
    const Eigen::Matrix2d w = m.inverse();
    const Eigen::Vector2d v_free = qd + h * (w * tau);
    const BrakeImpulse brake = SolveBrakeImpulse(v_free, w, capacity, h);
    const Eigen::Vector2d tau_brake = brake.impulse_Nms / h;
    state_.motor_energy_J += tau_motor.dot(brake.velocity_rad_per_s) * h;
    const Eigen::Vector2d brake_impulse = brake_share.cwiseProduct(brake.impulse_Nms);
    const Eigen::Vector2d friction_impulse = brake.impulse_Nms - brake_impulse;
    state_.brake_energy_J += brake_impulse.dot(brake.velocity_rad_per_s);
    state_.friction_energy_J += friction_impulse.dot(brake.velocity_rad_per_s);
    state_.joint_velocity_rad_per_s = brake.velocity_rad_per_s;
    state_.joint_rad += h * state_.joint_velocity_rad_per_s;
    state_.motor_joint_Nm = tau_motor;
    state_.brake_capacity_joint_Nm = capacity;
    for (int i = 0; i < 2; ++i) stuck_[i] = brake.velocity_rad_per_s(i) == 0.0;
    brake_sum_Nm += brake_share.cwiseProduct(tau_brake);
    friction_sum_Nm += tau_brake - brake_share.cwiseProduct(tau_brake);
  }
  state_.brake_joint_Nm = brake_sum_Nm / config_.substeps;
  state_.friction_joint_Nm = friction_sum_Nm / config_.substeps;
  state_.measured_hand_force_N = MeasureHandleForce(config_.force_sensor, hand_force_N);
  UpdateCartesian();
}

}  // namespace teleop::device::hybrid
