#pragma once

#include <string>

#include "teleop/proto/can/bus_load.hpp"
#include "teleop/proto/can/wire_format.hpp"
#include "teleop/transport/can_link_config.hpp"

namespace teleop::transport {

/// The wire format both ends derive from a CanLinkConfig.
proto::can::CanWireFormat WireFormatOf(const CanLinkConfig& config) noexcept;
proto::can::CanBitrates BitratesOf(const CanLinkConfig& config) noexcept;

/// The bus-load budget for `config` at `rate_hz`. Throws teleop::Error when the configuration is invalid (dof,
/// identifiers, bit rates, limit) or the load is above config.max_bus_load; the message carries the numbers
/// (FormatBusLoad) and what to change.
proto::can::BusLoad CheckCanBusBudget(const CanLinkConfig& config, double rate_hz);

/// "CAN classic 1000 kbit/s, 3 DOF at 1000 Hz: 2 frames/cycle/direction, 270 bits (minimum 270, 1.00x),
///  270.0 us/direction, bus load 54.0 % (limit 70 %)".
std::string FormatBusLoad(const proto::can::BusLoad& load, const CanLinkConfig& config, double rate_hz);

}  // namespace teleop::transport
