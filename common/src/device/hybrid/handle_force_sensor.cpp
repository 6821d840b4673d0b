#include "device/hybrid/handle_force_sensor.hpp"

#include <cmath>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {

void HandleForceSensorConfig::Validate() const {
  if (!bias_N.allFinite() || !std::isfinite(resolution_N) || resolution_N < 0.0) {
    throw Error("hybrid force sensor: bias_N must be finite and resolution_N >= 0");
  }
}

Eigen::Vector2d MeasureHandleForce(const HandleForceSensorConfig& config,
                                   const Eigen::Vector2d& true_force_N) noexcept {
  Eigen::Vector2d out = true_force_N + config.bias_N;
  if (config.resolution_N > 0.0) {
    for (int i = 0; i < 2; ++i) {
      out(i) = config.resolution_N * std::round(out(i) / config.resolution_N);
    }
  }
  return out;
}

}  // namespace teleop::device::hybrid
