#include "device/hybrid/particle_brake.hpp"

#include <algorithm>
#include <cmath>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {

void BrakeConfig::Validate() const {
  const bool finite = std::isfinite(max_torque_Nm) && std::isfinite(time_constant_s) && std::isfinite(drag_Nm) &&
                      std::isfinite(hysteresis_Nm) && std::isfinite(pulley_ratio) && std::isfinite(residual_fraction) &&
                      std::isfinite(static_ratio);
  if (!finite || max_torque_Nm <= 0.0 || pulley_ratio <= 0.0 || time_constant_s < 0.0 || drag_Nm < 0.0 ||
      hysteresis_Nm < 0.0 || residual_fraction < 0.0 || residual_fraction > 1.0 || static_ratio < 1.0) {
    throw Error(
        "hybrid brake: max_torque_Nm and pulley_ratio must be > 0; time_constant_s, drag_Nm, hysteresis_Nm >= 0; "
        "residual_fraction 0..1; static_ratio >= 1");
  }
}

ParticleBrake::ParticleBrake(const BrakeConfig& config) : config_(config) { config_.Validate(); }

double ParticleBrake::Step(double command_shaft_Nm, double period_s) noexcept {
  const double target =
      std::isfinite(command_shaft_Nm) ? std::clamp(command_shaft_Nm, 0.0, config_.max_torque_Nm) : 0.0;
  if (config_.time_constant_s <= 0.0) {
    lagged_shaft_Nm_ = target;
  } else {
    const double alpha = 1.0 - std::exp(-std::max(0.0, period_s) / config_.time_constant_s);
    lagged_shaft_Nm_ += alpha * (target - lagged_shaft_Nm_);
  }
  // Play operator: the output moves only when the input leaves the band of half-width h/2 around it.
  const double half = 0.5 * config_.hysteresis_Nm;
  delivered_shaft_Nm_ = std::clamp(delivered_shaft_Nm_, lagged_shaft_Nm_ - half, lagged_shaft_Nm_ + half);
  delivered_shaft_Nm_ = std::clamp(delivered_shaft_Nm_, 0.0, config_.max_torque_Nm);
  // Remanence: the delivered torque never falls below the residual of the largest it has reached.
  peak_shaft_Nm_ = std::max(peak_shaft_Nm_, delivered_shaft_Nm_);
  delivered_shaft_Nm_ = std::max(delivered_shaft_Nm_, config_.residual_fraction * peak_shaft_Nm_);
  return capacity_joint_Nm();
}

double ParticleBrake::capacity_joint_Nm() const noexcept {
  return (config_.drag_Nm + delivered_shaft_Nm_) * config_.pulley_ratio;
}

void ParticleBrake::Reset() noexcept {
  lagged_shaft_Nm_ = 0.0;
  delivered_shaft_Nm_ = 0.0;
  peak_shaft_Nm_ = 0.0;
}

}  // namespace teleop::device::hybrid
