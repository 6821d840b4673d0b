#include "teleop/fieldbus/can_port_config.hpp"

#include "teleop/error.hpp"
#include "teleop/transport/can_socket_port.hpp"
#include "teleop/transport/can_udp_bus_port.hpp"

namespace teleop::fieldbus {

std::unique_ptr<CanPort> OpenCanPort(const CanPortConfig& config, const CanReceiveOptions& options) {
  switch (config.medium) {
    case transport::CanMedium::kSocketCan:
      return std::make_unique<transport::SocketCanPort>(config.interface_name, options);
    case transport::CanMedium::kEmulatedBus:
      return std::make_unique<transport::UdpCanBusPort>(config.emulated_bus_host, config.emulated_bus_port,
                                                        config.connect_timeout_ms, options);
  }
  throw Error("CAN port: unknown medium");
}

}  // namespace teleop::fieldbus
