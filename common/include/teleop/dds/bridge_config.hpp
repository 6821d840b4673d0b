#pragma once

#include <string>

namespace teleop::dds {

/// The `dds:` section of a process config (docs/dds.md): whether and where the process publishes its state,
/// events and run summary on DDS. Plain data; read by config/dds_config.cpp.
struct BridgeConfig {
  bool enabled = false;
  int domain_id = 0;            ///< DDS domain (ROS_DOMAIN_ID), 0..232.
  std::string pair = "teleop";  ///< Names this master/slave pair in the topics: rt/teleop/<pair>/<role>/...
  double state_rate_hz = 20.0;  ///< State messages per second, decimated from the loop rate (0.1..rate_hz).
  int ring_capacity = 256;      ///< State records buffered between the loop and the bridge thread (16..65536).
};

}  // namespace teleop::dds
