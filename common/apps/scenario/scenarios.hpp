#pragma once

#include <CLI/CLI.hpp>

namespace teleop::scenario {

/// Adds the Kwon & Song hybrid motor–brake scenarios (hybrid-fme, hybrid-wall, hybrid-friction) to `app`.
void AddHybridScenarios(CLI::App& app);
/// Adds the Colgate et al. cobot scenarios (cobot-caster, cobot-track, cobot-wall, cobot-stability) to `app`.
void AddCobotScenarios(CLI::App& app);

}  // namespace teleop::scenario
