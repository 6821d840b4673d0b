// teleop-scenario: runs the papers' experiments on the simulated rigs and prints their metrics.
#include <CLI/CLI.hpp>
#include <exception>
#include <iostream>

#include "scenarios.hpp"
#include "teleop/cli_help.hpp"
#include "teleop/version.hpp"

namespace {

int Run(int argc, char** argv) {
  CLI::App app{"teleop-scenario: the papers' experiments on the simulated rigs (CSV, PNG, metrics)"};
  app.set_version_flag("--version", teleop::VersionText("teleop-scenario"));
  teleop::StandardHelp(app);
  app.require_subcommand(1);
  teleop::scenario::AddHybridScenarios(app);
  teleop::scenario::AddCobotScenarios(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  // A scenario's own errors (bad options, unwritable outputs) reach here as exceptions with a message.
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "teleop-scenario: " << e.what() << "\n";
    return 1;
  } catch (...) {
    std::cerr << "teleop-scenario: unexpected error\n";
    return 1;
  }
}
