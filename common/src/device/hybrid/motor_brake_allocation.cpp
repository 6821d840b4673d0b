#include "device/hybrid/motor_brake_allocation.hpp"

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
  if (!(std::isfinite(brake_model_mismatch) && brake_model_mismatch >= 0.0 && brake_model_mismatch <= 0.9)) {
    throw Error("hybrid allocation: brake_model_mismatch must be 0..0.9");
  }
}

BrakeConfig AllocationBrakeModel(const BrakeConfig& brake, double mismatch) {
  BrakeConfig model = brake;
  model.time_constant_s = brake.time_constant_s * (1.0 - mismatch);
  model.max_torque_Nm = brake.max_torque_Nm * (1.0 + 0.5 * mismatch);
  model.residual_fraction = 0.0;
  model.static_ratio = 1.0;
  return model;
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
      !in.motor_force_N.allFinite() || !in.desired_force_N.allFinite() || !in.dissipative_force_N.allFinite()) {
    for (auto& b : brake_model_) {
      (void)b.Step(0.0, period_s);
    }
    return out;
  }
  const Eigen::Matrix2d jt = in.jacobian_m_per_rad.transpose();
  const Eigen::Vector2d tau_m = jt * in.motor_force_N;
  const Eigen::Vector2d tau_d = jt * in.desired_force_N;
  const Eigen::Vector2d tau_r = jt * in.dissipative_force_N;
  const Eigen::Vector2d tau_hand = jt * in.hand_force_N;
  const Eigen::Vector2d tau_total = tau_m + tau_d + tau_r;
  out.desired_joint_Nm = tau_total;
  const double ratio = config_.brake.pulley_ratio;
  for (int i = 0; i < 2; ++i) {
    const double qd = in.joint_velocity_rad_per_s(i);
    const bool moving = std::abs(qd) >= config_.rest_velocity_rad_per_s;
    // The direction a brake torque must have here: against the motion, or at rest against the applied torque.
    const double reference = moving ? qd : tau_hand(i);
    const auto opposes = [&](double tau) { return reference != 0.0 && tau * reference < 0.0; };
    // §3: brakes only where the force is desired opposite to the motion; at rest only while the hand's torque is the
    // larger (Fig. 5(b): a larger reaction releases the handle outward, which a brake can only resist).
    const double tau_active = tau_m(i) + tau_d(i);
    const bool released_outward = !moving && opposes(tau_active) && std::abs(tau_active) > std::abs(tau_hand(i));
    const bool may_brake = config_.use_brakes && opposes(tau_total(i)) && !released_outward;
    const bool desired_share = may_brake && in.brakes_for_desired && opposes(tau_d(i));
    double ask_joint = 0.0;
    if (may_brake) {
      ask_joint = (desired_share ? std::abs(tau_d(i)) : 0.0) + (opposes(tau_r(i)) ? std::abs(tau_r(i)) : 0.0);
      ask_joint = std::min(ask_joint, std::abs(tau_total(i)));
    }
    out.brake_engaged[i] = ask_joint > 0.0;
    out.brake_ask_joint_Nm(i) = ask_joint;
    const double drag_joint = config_.brake.drag_Nm * ratio;
    out.brake_shaft_Nm(i) = std::clamp(ask_joint / ratio - config_.brake.drag_Nm, 0.0, config_.brake.max_torque_Nm);
    const double capacity_now = brake_model_[i].capacity_joint_Nm();
    (void)brake_model_[i].Step(out.brake_shaft_Nm(i), period_s);
    double motor = tau_m(i) + tau_d(i);
    if (out.brake_engaged[i]) {
      // The brake exerts min(capacity, ask) against the reference direction. It serves the shared request first
      // (the motor gives the rest of τ_d, same sign, never more), then the brakes-only request on top.
      const double estimate = std::min(capacity_now, ask_joint);
      out.brake_estimate_joint_Nm(i) = -std::copysign(estimate, reference);
      if (desired_share) {
        motor -= std::copysign(std::min(estimate, std::abs(tau_d(i))), tau_d(i));
      }
    } else if (moving) {
      // Brake released: its drag still resists the motion. The motor does not cancel it (that could inject energy).
      out.brake_estimate_joint_Nm(i) = -std::copysign(std::min(drag_joint, capacity_now), qd);
    }
    out.motor_joint_Nm(i) = motor;
  }
  return out;
}

}  // namespace teleop::device::hybrid
