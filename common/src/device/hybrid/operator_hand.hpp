#pragma once

#include <Eigen/Core>

namespace teleop::device::hybrid {

/// The simulated operator for the paper's experiments: a hand whose intended position x_ref moves from `start_m`
/// along `direction` at `speed_m_per_s` for `travel_m`, then holds; the hand follows it through a spring–damper
/// (arm stiffness and damping) and pushes the handle with F_h = sat(k·(x_ref − p) + b·(v_ref − v), max_force_N) —
/// a person pushes at a speed and up to a force. The hand's mass rides on the handle (HybridRigConfig adds it).
/// An optional sideways component (`side_direction`, `side_speed_m_per_s`, starting at `side_start_s`) drives the
/// sliding of the friction experiment; then push and slide saturate separately (max_force_N, side_max_force_N).
struct OperatorHandConfig {
  Eigen::Vector2d start_m{0.0, 0.200};
  Eigen::Vector2d direction{0.0, 1.0};
  double speed_m_per_s = 0.25;
  double travel_m = 0.080;
  double stiffness_N_per_m = 3000.0;
  double damping_Ns_per_m = 40.0;
  double max_force_N = 25.0;
  Eigen::Vector2d side_direction{1.0, 0.0};
  double side_speed_m_per_s = 0.0;
  double side_start_s = 0.0;
  double side_travel_m = 0.0;
  double side_max_force_N = 40.0;
  /// The hand lets go at this time (s; < 0: never): its force falls to zero over release_ramp_s and stays there
  /// (its mass stays on the handle: a relaxed hand resting on it). Figs. 8–9's force–position plots end with the
  /// release of the wall; Fig. 5(b) is that release.
  double release_s = -1.0;
  double release_ramp_s = 0.02;
};

class OperatorHand {
 public:
  explicit OperatorHand(const OperatorHandConfig& config) : config_(config) {}
  /// Hand force on the handle at time t_s, handle at p with velocity v. Real-time safe.
  [[nodiscard]] Eigen::Vector2d Force(double t_s, const Eigen::Vector2d& position_m,
                                      const Eigen::Vector2d& velocity_m_per_s) const noexcept;
  /// The intended position and velocity at t_s.
  void Reference(double t_s, Eigen::Vector2d& position_m, Eigen::Vector2d& velocity_m_per_s) const noexcept;
  const OperatorHandConfig& config() const noexcept { return config_; }

 private:
  OperatorHandConfig config_;
};

}  // namespace teleop::device::hybrid
