#include "scenarios.hpp"

namespace teleop::scenario {

void AddHybridScenarios(CLI::App& /*app*/) {}

}  // namespace teleop::scenario
