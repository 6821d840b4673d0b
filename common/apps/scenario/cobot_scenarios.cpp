#include "scenarios.hpp"

namespace teleop::scenario {

void AddCobotScenarios(CLI::App& /*app*/) {}

}  // namespace teleop::scenario
