#pragma once

#include "teleop/types.hpp"

namespace teleop::control {

/// Velocity from sampled position by backward difference (Abbott & Okamura eq. 20),
/// v(k) = (x(k) - x(k-1)) / T, optionally smoothed by a discrete first-order low-pass
/// y(k) = y(k-1) + a·(v(k) - y(k-1)), a = 1 - exp(-2π·f_c·T) (the paper's rig used f_c = 200 Hz).
///
/// `a` is the exact discretisation of the continuous pole at -2π·f_c for a sampled input held over one period; it
/// is recomputed only when the period changes. With f_c = 0 the output is the raw backward difference.
class VelocityEstimator {
 public:
  struct Config {
    int dof = 1;
    double cutoff_hz = 0.0;  ///< 0: no filter, the raw backward difference.
  };
  struct State {
    DofVector previous_position_m;
    DofVector velocity_m_per_s;      ///< Filtered output (equals the raw difference when cutoff_hz = 0).
    DofVector raw_velocity_m_per_s;  ///< Last unfiltered backward difference.
    bool primed = false;  ///< False until the first sample: the first velocity is 0, not a jump from the origin.
  };

  /// A 1-DOF estimator without filter.
  VelocityEstimator();
  /// Validates the config (dof in 1..kMaxDof, cutoff finite and ≥ 0); throws teleop::Error otherwise.
  explicit VelocityEstimator(const Config& config);

  /// Feeds one position sample (m) taken `period_s` after the previous one; returns the velocity (m/s).
  /// A sample of the wrong size, a non-finite sample or a period that is not finite and > 0 leaves the state
  /// unchanged and returns the previous velocity. Allocation-free.
  [[nodiscard]] const DofVector& Step(const DofVector& position_m, double period_s) noexcept;
  /// Forgets the history: the next sample primes the estimator again (velocity 0).
  void Reset() noexcept;
  /// The position's frame moved by `offset_m` (a clutch re-index): the history moves with it, so the jump is not
  /// seen as velocity. A vector of the wrong size or with NaN/inf is ignored. Allocation-free.
  void Shift(const DofVector& offset_m) noexcept;

  /// The filter coefficient a for a period (1 when the filter is off).
  [[nodiscard]] double FilterCoefficient(double period_s) const noexcept;

  const State& state() const noexcept { return state_; }
  const Config& config() const noexcept { return config_; }

 private:
  Config config_{};
  State state_{};
  double cached_period_s_ = 0.0;
  double cached_coefficient_ = 1.0;
};

}  // namespace teleop::control
