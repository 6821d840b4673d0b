#pragma once

#include "teleop/types.hpp"

namespace teleop::node {

/// The whole process: command line (CLI11), config, stability check, device, link, signals, summary.
/// `teleop-master` and `teleop-slave` call this with their role; the config's role must match.
/// `--list-devices` prints the registered device backends (capabilities, config keys) and exits.
int ProcessMain(int argc, char** argv, Role role);

}  // namespace teleop::node
