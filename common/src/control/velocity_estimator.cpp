#include "teleop/control/velocity_estimator.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "teleop/error.hpp"

namespace teleop::control {

VelocityEstimator::VelocityEstimator() : VelocityEstimator(Config{}) {}

VelocityEstimator::VelocityEstimator(const Config& config) : config_(config) {
  if (config.dof < 1 || config.dof > kMaxDof) {
    throw Error("velocity estimator: dof " + std::to_string(config.dof) + " is out of range; use 1.." +
                std::to_string(kMaxDof));
  }
  if (!std::isfinite(config.cutoff_hz) || config.cutoff_hz < 0.0) {
    throw Error("velocity estimator: cutoff_hz " + std::to_string(config.cutoff_hz) +
                " must be finite and >= 0 (0 turns the low-pass off)");
  }
  Reset();
}

double VelocityEstimator::FilterCoefficient(double period_s) const noexcept {
  if (config_.cutoff_hz <= 0.0) return 1.0;
  return 1.0 - std::exp(-2.0 * std::numbers::pi * config_.cutoff_hz * period_s);
}

const DofVector& VelocityEstimator::Step(const DofVector& position_m, double period_s) noexcept {
  if (position_m.size() != config_.dof || !AllFinite(position_m) || !std::isfinite(period_s) || period_s <= 0.0) {
    return state_.velocity_m_per_s;
  }
  if (!state_.primed) {
    state_.previous_position_m = position_m;
    state_.velocity_m_per_s.setZero();
    state_.raw_velocity_m_per_s.setZero();
    state_.primed = true;
    return state_.velocity_m_per_s;
  }
  if (period_s != cached_period_s_) {
    cached_period_s_ = period_s;
    cached_coefficient_ = FilterCoefficient(period_s);
  }
  state_.raw_velocity_m_per_s = (position_m - state_.previous_position_m) / period_s;
  if (config_.cutoff_hz > 0.0) {
    state_.velocity_m_per_s += cached_coefficient_ * (state_.raw_velocity_m_per_s - state_.velocity_m_per_s);
  } else {
    state_.velocity_m_per_s = state_.raw_velocity_m_per_s;
  }
  state_.previous_position_m = position_m;
  return state_.velocity_m_per_s;
}

void VelocityEstimator::Reset() noexcept {
  state_.previous_position_m = DofVector::Zero(config_.dof);
  state_.velocity_m_per_s = DofVector::Zero(config_.dof);
  state_.raw_velocity_m_per_s = DofVector::Zero(config_.dof);
  state_.primed = false;
}

void VelocityEstimator::Shift(const DofVector& offset_m) noexcept {
  if (offset_m.size() != config_.dof || !AllFinite(offset_m) || !state_.primed) return;
  state_.previous_position_m += offset_m;
}

}  // namespace teleop::control
