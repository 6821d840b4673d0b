#pragma once

// A driver's CAN port from its config section: CanPortConfig and OpenCanPort (the port's interface, CanPort, is
// teleop/transport/can_port.hpp).

#include <cstdint>
#include <memory>
#include <string>

#include "teleop/transport/can_filter.hpp"
#include "teleop/transport/can_link_config.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::fieldbus {

// A driver's access to a CAN bus is the same CanPort the master-slave link uses (docs/can.md): non-blocking
// Write/Read of proto::can::CanFrame from the real-time thread, error frames read like data frames.
using transport::CanFilter;
using transport::CanPort;
using transport::CanReceiveOptions;
using transport::CanWriteStatus;

/// Where a driver's CAN frames go (a driver's config section): a SocketCAN interface or a teleop-canbus daemon.
struct CanPortConfig {
  transport::CanMedium medium = transport::CanMedium::kSocketCan;
  std::string interface_name = "can0";          ///< SocketCAN interface (can0, vcan0, ...).
  std::string emulated_bus_host = "127.0.0.1";  ///< teleop-canbus address (kEmulatedBus).
  std::uint16_t emulated_bus_port = 47300;      ///< teleop-canbus UDP port (kEmulatedBus).
  double connect_timeout_ms = 1000.0;           ///< How long to wait for teleop-canbus at start-up.
};

/// Opens a port on the medium of `config` that receives what `options` lets through (filters, error mask, FD).
/// Set-up only; throws teleop::Error with what to do (no AF_CAN, no interface, no daemon, too many filters).
/// For the in-process emulated bus use transport::EmulatedCanBus::MakePort(node, options).
std::unique_ptr<CanPort> OpenCanPort(const CanPortConfig& config, const CanReceiveOptions& options);

}  // namespace teleop::fieldbus
