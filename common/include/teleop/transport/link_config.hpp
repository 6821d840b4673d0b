#pragma once

#include <memory>
#include <string>

#include "teleop/transport/link.hpp"
#include "teleop/transport/udp_link.hpp"

namespace teleop::transport {

/// Per-process link selection. `transport` is "udp" (later also "can", "emulated-can").
struct LinkConfig {
  std::string transport = "udp";
  UdpLinkConfig udp{};
  double timeout_ms = 50.0;  ///< Watchdog: no accepted sample for this long → peer lost → safe state.
};

/// Opens the configured link for a process of role `local_role`. Throws teleop::Error on failure.
std::unique_ptr<Link> MakeLink(const LinkConfig& config, proto::SenderRole local_role);

}  // namespace teleop::transport
