#pragma once

#include <string>

#include "teleop/control/three_channel_law.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "teleop/transport/link_config.hpp"
#include "teleop/types.hpp"

namespace teleop::config {

/// Where per-cycle telemetry goes. Written by a non-real-time thread fed through a lock-free ring.
struct TelemetryConfig {
  std::string csv_path;       ///< Empty: no CSV.
  int decimation = 1;         ///< Record every n-th cycle (the caller decimates before TelemetryWriter::Push).
  int ring_capacity = 16384;  ///< Records buffered between the loop and the writer (16..2^24; ~430 B each).
};

/// Everything one process (teleop-master or teleop-slave) needs, read from one YAML file.
/// See docs/configuration.md for every key, its unit and range.
struct ProcessConfig {
  Role role = Role::kMaster;
  int dof = 1;
  runtime::PeriodicLoopConfig loop{};
  transport::LinkConfig link{};
  device::DeviceConfig device{};
  control::ThreeChannelLaw::Config law{};
  TelemetryConfig telemetry{};
  std::string source_path;  ///< The file it was read from (for messages).
};

}  // namespace teleop::config
