#include "teleop/device/hybrid/motor_brake_allocation.hpp"

#include <algorithm>
#include <cmath>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {

void AllocationConfig::Validate() const {
  motor.Validate();
  brake.Validate();
  if (!(std::isfinite(rest_velocity_rad_per_s) && rest_velocity_rad_per_s >= 0.0)) {
    throw Error("hybrid allocation: rest_velocity_rad_per_s must be finite and >= 0");
  }
}

MotorBrakeAllocator::MotorBrakeAllocator(const AllocationConfig& config)
    : config_(config), brake_model_{ParticleBrake(config.brake), ParticleBrake(config.brake)} {
  config_.Validate();
}

void MotorBrakeAllocator::Reset() noexcept {
  brake_model_[0].Reset();
  brake_model_[1].Reset();
}

AllocationOutput MotorBrakeAllocator::Step(const AllocationInput& in, double period_s) noexcept {
  AllocationOutput out;
  if (!in.jacobian_m_per_rad.allFinite() || !in.joint_velocity_rad_per_s.allFinite() || !in.hand_force_N.allFinite() ||
      !in.desired_force_N.allFinite() || !in.dissipative_force_N.allFinite()) {
    for (auto& b : brake_model_) {
      (void)b.Step(0.0, period_s);
    }
    return out;
  }
  const Eigen::Matrix2d jt = in.jacobian_m_per_rad.transpose();
  const Eigen::Vector2d tau_d = jt * in.desired_force_N;
  const Eigen::Vector2d tau_diss = jt * in.dissipative_force_N;
  const Eigen::Vector2d tau_hand = jt * in.hand_force_N;
  out.desired_joint_Nm = tau_d;
  const double ratio = config_.brake.pulley_ratio;
  for (int i = 0; i < 2; ++i) {
    const double qd = in.joint_velocity_rad_per_s(i);
    const bool moving = std::abs(qd) >= config_.rest_velocity_rad_per_s;
    // The direction a brake torque must have here: against the motion, or at rest against the applied torque.
    const double reference = moving ? qd : tau_hand(i);
    const auto dissipative = [&](double tau) { return reference != 0.0 && tau * reference < 0.0; };
    double ask_joint = 0.0;
    if (config_.use_brakes) {
      if (in.brakes_for_desired && dissipative(tau_d(i))) {
        ask_joint = std::abs(tau_d(i));
      }
      if (dissipative(tau_diss(i))) {
        ask_joint = std::max(ask_joint, std::abs(tau_diss(i)));
      }
    }
    out.brake_engaged[i] = ask_joint > 0.0;
    const double drag_joint = config_.brake.drag_Nm * ratio;
    out.brake_shaft_Nm(i) = std::clamp(ask_joint / ratio - config_.brake.drag_Nm, 0.0, config_.brake.max_torque_Nm);
    const double capacity_now = brake_model_[i].capacity_joint_Nm();
    (void)brake_model_[i].Step(out.brake_shaft_Nm(i), period_s);
    double motor = tau_d(i);
    if (out.brake_engaged[i] && in.brakes_for_desired && dissipative(tau_d(i))) {
      // The brake exerts min(capacity, what is needed) against the reference direction; the motor adds the rest of
      // the desired torque, same sign, never more.
      const double brake_share = std::min(capacity_now, std::abs(tau_d(i)));
      out.brake_estimate_joint_Nm(i) = std::copysign(brake_share, tau_d(i));
      motor = tau_d(i) - out.brake_estimate_joint_Nm(i);
    } else if (moving) {
      // Brake released: its drag still resists the motion. The motor does not cancel it (that could inject energy).
      out.brake_estimate_joint_Nm(i) = -std::copysign(std::min(drag_joint, capacity_now), qd);
    }
    out.motor_joint_Nm(i) = motor;
  }
  return out;
}

}  // namespace teleop::device::hybrid
