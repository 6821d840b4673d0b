#include "device/hybrid/passivity_observer.hpp"

#include <algorithm>
#include <cmath>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {

void PassivityObserverConfig::Validate() const {
  if (!(std::isfinite(actuator_time_constant_s) && actuator_time_constant_s >= 0.0) ||
      !(std::isfinite(max_damping_Ns_per_m) && max_damping_Ns_per_m >= 0.0) ||
      !(std::isfinite(max_force_N) && max_force_N > 0.0)) {
    throw Error(
        "hybrid PO/PC: actuator_time_constant_s and max_damping_Ns_per_m must be finite and >= 0, max_force_N > 0");
  }
}

PassivityObserver::PassivityObserver(const PassivityObserverConfig& config) : config_(config) { config_.Validate(); }

void PassivityObserver::Reset() noexcept {
  delivered_N_.setZero();
  applied_N_.setZero();
  energy_J_ = 0.0;
  dissipated_J_ = 0.0;
  alpha_Ns_per_m_ = 0.0;
}

Eigen::Vector2d PassivityObserver::Step(const Eigen::Vector2d& environment_force_N,
                                        const Eigen::Vector2d& velocity_m_per_s, double period_s) noexcept {
  if (!velocity_m_per_s.allFinite() || !(period_s > 0.0) || !std::isfinite(period_s)) {
    return Eigen::Vector2d::Zero();
  }
  return Step(environment_force_N, velocity_m_per_s * period_s, velocity_m_per_s, period_s);
}

Eigen::Vector2d PassivityObserver::Step(const Eigen::Vector2d& environment_force_N,
                                        const Eigen::Vector2d& displacement_m, const Eigen::Vector2d& velocity_m_per_s,
                                        double period_s) noexcept {
  if (!environment_force_N.allFinite() || !velocity_m_per_s.allFinite() || !displacement_m.allFinite() ||
      !(period_s > 0.0) || !std::isfinite(period_s)) {
    return Eigen::Vector2d::Zero();
  }
  const Eigen::Vector2d& v = velocity_m_per_s;
  const double v2 = v.squaredNorm();
  // Observer: the work of the force applied over the last period, F_app(n−1), through the displacement over it
  // (the encoders' Δx, or v(n)·T). It holds the controller's past dissipation once.
  energy_J_ -= applied_N_.dot(displacement_m);
  // Controller (Hannaford & Ryu 2002, impedance form): α from the observed energy plus this step's f(n)·v(n)·T.
  const double predicted_J = energy_J_ - environment_force_N.dot(v) * period_s;
  alpha_Ns_per_m_ = 0.0;
  if (predicted_J < 0.0 && v2 > 1e-12) {
    alpha_Ns_per_m_ = std::min(-predicted_J / (period_s * v2), config_.max_damping_Ns_per_m);
  }
  Eigen::Vector2d command = environment_force_N - alpha_Ns_per_m_ * v;
  const double norm = command.norm();
  if (norm > config_.max_force_N) {
    command *= config_.max_force_N / norm;
  }
  // Actuator model: first-order lag under the held command; the force applied over the period is its exact mean.
  if (config_.actuator_time_constant_s > 0.0) {
    const double r = period_s / config_.actuator_time_constant_s;
    const double decay = std::exp(-r);
    const Eigen::Vector2d start = delivered_N_;
    delivered_N_ = command + (start - command) * decay;
    applied_N_ = command + (start - command) * ((1.0 - decay) / r);
  } else {
    delivered_N_ = command;
    applied_N_ = command;
  }
  dissipated_J_ += alpha_Ns_per_m_ * v2 * period_s;
  return command;
}

}  // namespace teleop::device::hybrid
