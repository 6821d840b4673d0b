#include "teleop/device/hybrid/passivity_observer.hpp"

#include <algorithm>
#include <cmath>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {

void PassivityObserverConfig::Validate() const {
  if (!(std::isfinite(actuator_time_constant_s) && actuator_time_constant_s >= 0.0) ||
      !(std::isfinite(max_damping_Ns_per_m) && max_damping_Ns_per_m >= 0.0)) {
    throw Error("hybrid PO/PC: actuator_time_constant_s and max_damping_Ns_per_m must be finite and >= 0");
  }
}

PassivityObserver::PassivityObserver(const PassivityObserverConfig& config) : config_(config) { config_.Validate(); }

void PassivityObserver::Reset() noexcept {
  delivered_N_.setZero();
  energy_J_ = 0.0;
  alpha_Ns_per_m_ = 0.0;
}

Eigen::Vector2d PassivityObserver::Step(const Eigen::Vector2d& environment_force_N,
                                        const Eigen::Vector2d& velocity_m_per_s, double period_s) noexcept {
  if (!environment_force_N.allFinite() || !velocity_m_per_s.allFinite() || !(period_s > 0.0)) {
    return Eigen::Vector2d::Zero();
  }
  // Energy through the port over the last period, with the force the motors delivered over it.
  energy_J_ += -delivered_N_.dot(velocity_m_per_s) * period_s;
  Eigen::Vector2d command = environment_force_N;
  alpha_Ns_per_m_ = 0.0;
  const double v2 = velocity_m_per_s.squaredNorm();
  if (energy_J_ < 0.0 && v2 > 1e-12) {
    alpha_Ns_per_m_ = std::min(-energy_J_ / (period_s * v2), config_.max_damping_Ns_per_m);
    command -= alpha_Ns_per_m_ * velocity_m_per_s;
    energy_J_ += alpha_Ns_per_m_ * v2 * period_s;
  }
  const double a =
      config_.actuator_time_constant_s > 0.0 ? 1.0 - std::exp(-period_s / config_.actuator_time_constant_s) : 1.0;
  delivered_N_ += a * (command - delivered_N_);
  return command;
}

}  // namespace teleop::device::hybrid
