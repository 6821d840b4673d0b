#include "teleop/analysis/fixture_check.hpp"

#include <sstream>
#include <vector>

#include "teleop/analysis/human_bounds.hpp"
#include "teleop/error.hpp"

namespace teleop::analysis {

FixtureCheck CheckFixture(const SampledTeleoperator& system, FixtureSide side, std::span<const HumanModel> humans) {
  std::vector<HumanModel> default_humans;
  if (humans.empty()) {
    default_humans = MakeHumanGrid(DefaultFingerBounds(), 4);
    humans = default_humans;
  }
  FixtureCheck check;
  check.side = side;
  check.stiffness_N_per_m = system.gains.fixture(side);
  check.limit = FindMaxStableStiffness(system, side, humans);
  SampledTeleoperator effective = system;
  effective.gains = EffectiveGains(system, side);
  check.at_configured = EvaluateWorstCase(effective, humans);
  check.stable = !check.limit.unstable_without_fixture && check.at_configured.spectral_radius <= 1.0 + 1e-9;

  std::ostringstream msg;
  msg.precision(4);
  msg << ToString(side) << " fixture " << check.stiffness_N_per_m << " N/m is "
      << (check.stable ? "stable" : "UNSTABLE") << ": predicted limit " << check.limit.max_stable_stiffness_N_per_m
      << " N/m at " << system.rate_hz << " Hz (" << (system.unilateral ? "unilateral" : "bilateral") << ", "
      << DescribePeerDelay(system) << ", passivity bound " << check.limit.passivity_bound_N_per_m
      << " N/m); worst damping ratio " << check.at_configured.min_damping_ratio
      << " for operator m=" << check.at_configured.human.mass_kg
      << " kg b=" << check.at_configured.human.damping_Ns_per_m
      << " Ns/m k=" << check.at_configured.human.stiffness_N_per_m << " N/m";
  if (check.limit.unstable_without_fixture) msg << "; the law is unstable even without the fixture";
  check.message = msg.str();
  return check;
}

void EnforceFixtureLimit(const FixtureCheck& check, bool allow_unstable) {
  if (check.stable || allow_unstable) return;
  throw Error("refusing to start: " + check.message + ". Lower the fixture stiffness below " +
              std::to_string(check.limit.max_stable_stiffness_N_per_m) +
              " N/m, raise the rate or the damping, or pass --allow-unstable to run anyway (experiments only)");
}

}  // namespace teleop::analysis
