#pragma once

#include <span>
#include <string>

#include "teleop/analysis/stability_limit.hpp"

namespace teleop::analysis {

/// The start-up check of a process's forbidden-region fixture against the predicted limit (and what
/// `teleop-analyze check` prints).
struct FixtureCheck {
  bool stable = false;  ///< configured stiffness ≤ predicted limit (and the limit is not 0).
  FixtureSide side = FixtureSide::kMaster;
  double stiffness_N_per_m = 0.0;  ///< The configured fixture stiffness of `side`.
  StabilityLimit limit{};          ///< The predicted limit for `side`.
  WorstCase at_configured{};       ///< Worst operator and ζ at the configured stiffness.
  std::string message;             ///< One line: verdict, stiffness, limit, worst ζ and operator.
};

/// Analyses the configured fixture of `side` (the stiffness in system.gains) over `humans` (empty: the default
/// finger grid, DefaultFingerBounds with 4 steps). The processes pass peer_delay_samples = 1. Throws teleop::Error
/// on an invalid system.
FixtureCheck CheckFixture(const SampledTeleoperator& system, FixtureSide side, std::span<const HumanModel> humans = {});

/// Start-up refusal: throws teleop::Error with check.message and the override hint when the check failed and
/// `allow_unstable` is false; returns normally otherwise.
void EnforceFixtureLimit(const FixtureCheck& check, bool allow_unstable);

}  // namespace teleop::analysis
