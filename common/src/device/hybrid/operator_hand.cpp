#include "device/hybrid/operator_hand.hpp"

#include <algorithm>

namespace teleop::device::hybrid {

void OperatorHand::Reference(double t_s, Eigen::Vector2d& position_m,
                             Eigen::Vector2d& velocity_m_per_s) const noexcept {
  const double push_time = config_.speed_m_per_s > 0.0 ? config_.travel_m / config_.speed_m_per_s : 0.0;
  const double tp = std::clamp(t_s, 0.0, push_time);
  position_m = config_.start_m + config_.direction * config_.speed_m_per_s * tp;
  velocity_m_per_s =
      t_s < push_time ? Eigen::Vector2d(config_.direction * config_.speed_m_per_s) : Eigen::Vector2d::Zero();
  if (config_.side_speed_m_per_s > 0.0 && t_s > config_.side_start_s) {
    const double side_time = config_.side_travel_m / config_.side_speed_m_per_s;
    const double ts = std::min(t_s - config_.side_start_s, side_time);
    position_m += config_.side_direction * config_.side_speed_m_per_s * ts;
    if (t_s - config_.side_start_s < side_time) {
      velocity_m_per_s += config_.side_direction * config_.side_speed_m_per_s;
    }
  }
}

Eigen::Vector2d OperatorHand::Force(double t_s, const Eigen::Vector2d& position_m,
                                    const Eigen::Vector2d& velocity_m_per_s) const noexcept {
  Eigen::Vector2d p_ref;
  Eigen::Vector2d v_ref;
  Reference(t_s, p_ref, v_ref);
  Eigen::Vector2d f =
      config_.stiffness_N_per_m * (p_ref - position_m) + config_.damping_Ns_per_m * (v_ref - velocity_m_per_s);
  double grip = 1.0;  // 1 holding, 0 let go
  if (config_.release_s >= 0.0 && t_s >= config_.release_s) {
    grip = config_.release_ramp_s > 0.0 ? std::clamp(1.0 - (t_s - config_.release_s) / config_.release_ramp_s, 0.0, 1.0)
                                        : 0.0;
  }
  if (config_.side_speed_m_per_s <= 0.0) {
    const double n = f.norm();
    if (n > config_.max_force_N && n > 0.0) {
      f *= config_.max_force_N / n;
    }
    return grip * f;
  }
  // Push and slide saturate separately (a person presses and drags with separate effort); directions orthogonal.
  const double push = std::clamp(f.dot(config_.direction), -config_.max_force_N, config_.max_force_N);
  const double side = std::clamp(f.dot(config_.side_direction), -config_.side_max_force_N, config_.side_max_force_N);
  f = push * config_.direction + side * config_.side_direction;
  return grip * f;
}

}  // namespace teleop::device::hybrid
