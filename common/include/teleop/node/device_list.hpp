#pragma once

#include <string>

namespace teleop::node {

/// The registered device backends as `--list-devices` prints them: per backend its name, description, what it
/// renders, its sensors, whether it has a brake, and every config key of `device.<name>` with its description.
std::string DescribeDevices();

}  // namespace teleop::node
