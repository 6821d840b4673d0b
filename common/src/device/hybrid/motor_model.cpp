#include "device/hybrid/motor_model.hpp"

#include <algorithm>
#include <cmath>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {

void MotorConfig::Validate() const {
  if (!(std::isfinite(max_torque_Nm) && max_torque_Nm > 0.0) || !(std::isfinite(pulley_ratio) && pulley_ratio > 0.0) ||
      !(std::isfinite(time_constant_s) && time_constant_s >= 0.0)) {
    throw Error("hybrid motor: max_torque_Nm and pulley_ratio must be > 0, time_constant_s >= 0");
  }
}

MotorModel::MotorModel(const MotorConfig& config) : config_(config) { config_.Validate(); }

double MotorModel::Step(double command_joint_Nm, double period_s) noexcept {
  const double limit = config_.MaxJointTorqueNm();
  const double target = std::isfinite(command_joint_Nm) ? std::clamp(command_joint_Nm, -limit, limit) : 0.0;
  if (config_.time_constant_s <= 0.0) {
    torque_joint_Nm_ = target;
  } else {
    const double alpha = 1.0 - std::exp(-std::max(0.0, period_s) / config_.time_constant_s);
    torque_joint_Nm_ += alpha * (target - torque_joint_Nm_);
  }
  return torque_joint_Nm_;
}

}  // namespace teleop::device::hybrid
