#pragma once

#include <span>

#include "teleop/analysis/teleoperator_model.hpp"

namespace teleop::analysis {

/// The worst operator of a set for one system (the paper's Fig. 5 algorithm).
struct WorstCase {
  double min_damping_ratio = 1.0;  ///< Lowest ζ over all operators and eigenvalues; < 0: unstable.
  double spectral_radius = 0.0;    ///< Largest |z| over all operators.
  HumanModel human{};              ///< The operator with the lowest ζ.
  int models_evaluated = 0;
};

/// Fig. 5: builds the model for every operator, with the gains and both fixture stiffnesses of `system` as given
/// (`unilateral` removes K_pm, K_dm, K_fm; apply EffectiveGains first for the saturated-master case), and keeps the
/// lowest damping ratio. Throws teleop::Error on an invalid system, an invalid operator or an empty set.
WorstCase EvaluateWorstCase(const SampledTeleoperator& system, std::span<const HumanModel> humans);

/// Result of the stiffness search.
struct StabilityLimit {
  /// Largest fixture stiffness of `side` for which every operator gives a stable equilibrium (to the requested
  /// relative tolerance, from below). 0 when the system is unstable even without the fixture.
  double max_stable_stiffness_N_per_m = 0.0;
  /// The first stiffness found unstable (the bracket's upper end): the limit lies in [max_stable, this].
  double min_unstable_stiffness_N_per_m = 0.0;
  /// Lowest ζ and the operator that gives it, at max_stable_stiffness_N_per_m (≥ 0, close to 0 at the limit).
  double worst_damping_ratio = 0.0;
  HumanModel worst_human{};
  /// The operator that first became unstable just above the limit (the one that sets the limit).
  HumanModel limiting_human{};
  /// Colgate & Schenkel's sufficient passivity condition for the same side, for comparison (Fig. 14).
  double passivity_bound_N_per_m = 0.0;
  bool unstable_without_fixture = false;
  int bisection_steps = 0;
  int models_evaluated = 0;
};

struct LimitOptions {
  double relative_tolerance = 1e-3;    ///< Bracket width / limit at which the bisection stops (0.1 %).
  double max_stiffness_N_per_m = 1e9;  ///< Search cap; reported as the limit if nothing below it is unstable.
  int threads = 0;  ///< Operator set split over this many threads; 0: one per hardware thread (≤ 8).
  /// Delays over one sample only (the delay-line model): the bracket [0, hi] is walked up in this many equal steps
  /// before the bisection, so an unstable window below a stable probe is found (each step is a pass over the set).
  /// ≤ 1: no walk.
  int delay_scan_points = 8;
};

/// Maximum stable fixture stiffness of `side` over the operator set: the first stiffness, counting up from 0, at
/// which an operator is unstable (0 and unstable_without_fixture when the coupling alone is), by bracketing (0, a
/// first guess growing ×4, with delay lines a walk over the bracket) and bisection on the largest eigenvalue
/// magnitude. The gains of `system` for the searched fixture are ignored (they are the unknown); the
/// other side's fixture is kept. Each step stops at the first unstable operator, trying the last one that was
/// unstable first. Throws teleop::Error on invalid input.
StabilityLimit FindMaxStableStiffness(const SampledTeleoperator& system, FixtureSide side,
                                      std::span<const HumanModel> humans, const LimitOptions& options = {});

/// Colgate & Schenkel (1997): a sampled virtual wall K + B(1 - z⁻¹)/T on a device of physical damping b is passive
/// if b > K·T/2 + |B|. Applied to the local impedance the analysed side renders from its own position
/// (K = K_p + K_VF, B = K_d + K_v of that side, after `unilateral`): K_VF ≤ 2(b - |B|)/T - K_p, clamped at 0.
double PassivityBound(const SampledTeleoperator& system, FixtureSide side) noexcept;

}  // namespace teleop::analysis
