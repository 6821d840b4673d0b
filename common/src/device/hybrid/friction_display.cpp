#include "device/hybrid/friction_display.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {

void FrictionConfig::Validate() const {
  if (!point_m.allFinite() || !normal.allFinite() || std::abs(normal.norm() - 1.0) > 1e-6) {
    throw Error("hybrid friction: point_m must be finite and normal a unit vector");
  }
  for (double v : {stiffness_N_per_m, damping_Ns_per_m, max_normal_force_N, static_coefficient, kinetic_coefficient,
                   rest_speed_m_per_s}) {
    if (!std::isfinite(v) || v < 0.0) {
      throw Error("hybrid friction: stiffness, force limit, coefficients and rest speed must be finite and >= 0");
    }
  }
  if (kinetic_coefficient > static_coefficient) {
    throw Error("hybrid friction: kinetic_coefficient must not exceed static_coefficient");
  }
}

FrictionOutput FrictionStep(const FrictionConfig& config, const Eigen::Vector2d& position_m,
                            const Eigen::Vector2d& velocity_m_per_s,
                            const Eigen::Vector2d& measured_hand_force_N) noexcept {
  FrictionOutput out;
  if (!position_m.allFinite() || !velocity_m_per_s.allFinite() || !measured_hand_force_N.allFinite()) {
    return out;
  }
  const Eigen::Vector2d& n = config.normal;
  const Eigen::Vector2d t{n.y(), -n.x()};
  const double depth = (position_m - config.point_m).dot(n);
  out.in_contact = depth > 0.0;
  if (!out.in_contact) {
    return out;
  }
  const double normal_reaction =
      std::clamp(config.stiffness_N_per_m * depth + config.damping_Ns_per_m * velocity_m_per_s.dot(n), 0.0,
                 config.max_normal_force_N);
  out.desired_force_N = -normal_reaction * n;
  out.normal_force_N = std::max(0.0, measured_hand_force_N.dot(n));
  const double v_t = velocity_m_per_s.dot(t);
  const double f_t = measured_hand_force_N.dot(t);
  const bool sliding = std::abs(v_t) >= config.rest_speed_m_per_s;
  const double mu = sliding ? config.kinetic_coefficient : config.static_coefficient;
  out.friction_target_N = mu * out.normal_force_N;
  // The direction friction must have: against the sliding, or at rest against the operator's tangential push.
  const double reference = sliding ? v_t : f_t;
  if (reference == 0.0) {
    return out;
  }
  const double direction = reference > 0.0 ? -1.0 : 1.0;
  if (config.display == FrictionDisplay::kMotor) {
    const double magnitude = std::min(out.friction_target_N, std::abs(f_t));
    out.desired_force_N += direction * magnitude * t;
  } else {
    out.dissipative_force_N = direction * out.friction_target_N * t;
  }
  return out;
}

const char* ToString(FrictionDisplay display) noexcept {
  return display == FrictionDisplay::kMotor ? "motor" : "brake";
}

bool ParseFrictionDisplay(const char* text, FrictionDisplay& display) noexcept {
  if (text == nullptr) {
    return false;
  }
  if (std::strcmp(text, "motor") == 0) {
    display = FrictionDisplay::kMotor;
    return true;
  }
  if (std::strcmp(text, "brake") == 0) {
    display = FrictionDisplay::kBrake;
    return true;
  }
  return false;
}

}  // namespace teleop::device::hybrid
