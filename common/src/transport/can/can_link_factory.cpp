#include <spdlog/spdlog.h>

#include "teleop/error.hpp"
#include "teleop/transport/can_bus_budget.hpp"
#include "teleop/transport/can_link.hpp"
#include "teleop/transport/can_log_port.hpp"
#include "teleop/transport/can_socket_port.hpp"
#include "teleop/transport/can_udp_bus_port.hpp"

namespace teleop::transport {

std::unique_ptr<Link> MakeCanLink(const CanLinkConfig& config, proto::SenderRole local_role, double rate_hz) {
  const proto::can::BusLoad load = CheckCanBusBudget(config, rate_hz);  // throws with the numbers
  const std::string budget = FormatBusLoad(load, config, rate_hz);
  spdlog::info("CAN bus budget: {}", budget);
  const proto::can::CanWireFormat format = WireFormatOf(config);
  std::unique_ptr<CanPort> port;
  switch (config.medium) {
    case CanMedium::kSocketCan:
      port = std::make_unique<SocketCanPort>(config.interface_name, format, local_role);
      break;
    case CanMedium::kEmulatedBus:
      port = std::make_unique<UdpCanBusPort>(config.emulated_bus_host, config.emulated_bus_port,
                                             config.connect_timeout_ms);
      break;
  }
  if (!port) throw Error("CAN link: unknown medium");
  if (!config.log_path.empty()) {
    const std::string name = config.medium == CanMedium::kSocketCan ? config.interface_name : "vcan0";
    port = std::make_unique<CandumpLogPort>(std::move(port), config.log_path, name);
    spdlog::info("CAN: candump log of this process's frames in {} (interface name {})", config.log_path, name);
  }
  return std::make_unique<CanLink>(format, local_role, std::move(port), budget);
}

}  // namespace teleop::transport
