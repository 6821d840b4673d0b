#pragma once

#include "teleop/types.hpp"

namespace teleop::control {

/// Velocity from sampled position by backward difference (Abbott & Okamura eq. 20),
/// v(k) = (x(k) - x(k-1)) / T, optionally smoothed by a discrete first-order low-pass
/// y(k) = y(k-1) + a·(v(k) - y(k-1)), a = 1 - exp(-2π·f_c·T) (the paper's rig used f_c = 200 Hz).
class VelocityEstimator {
 public:
  struct Config {
    int dof = 1;
    double cutoff_hz = 0.0;  ///< 0: no filter, the raw backward difference.
  };
  struct State {
    DofVector previous_position_m;
    DofVector velocity_m_per_s;
    bool primed = false;  ///< False until the first sample: the first velocity is 0, not a jump from the origin.
  };

  VelocityEstimator() = default;
  explicit VelocityEstimator(const Config& config);

  /// Feeds one position sample (m) taken `period_s` after the previous one; returns the velocity (m/s).
  [[nodiscard]] const DofVector& Step(const DofVector& position_m, double period_s) noexcept;
  void Reset() noexcept;

  const State& state() const noexcept { return state_; }
  const Config& config() const noexcept { return config_; }

 private:
  Config config_{};
  State state_{};
};

}  // namespace teleop::control
