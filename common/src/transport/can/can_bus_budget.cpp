#include "teleop/transport/can_bus_budget.hpp"

#include <fmt/format.h>

#include <cmath>

#include "teleop/error.hpp"

namespace teleop::transport {

proto::can::CanWireFormat WireFormatOf(const CanLinkConfig& config) noexcept {
  proto::can::CanWireFormat f{};
  f.dof = config.dof;
  f.fd = config.fd;
  f.brs = config.bit_rate_switch;
  f.extended_id = config.extended_id;
  f.master_to_slave_base_id = config.master_to_slave_base_id;
  f.slave_to_master_base_id = config.slave_to_master_base_id;
  return f;
}

proto::can::CanBitrates BitratesOf(const CanLinkConfig& config) noexcept {
  return proto::can::CanBitrates{config.nominal_bitrate_bit_per_s, config.data_bitrate_bit_per_s};
}

std::string FormatBusLoad(const proto::can::BusLoad& load, const CanLinkConfig& config, double rate_hz) {
  const std::string bus =
      config.fd ? fmt::format("CAN FD {:.0f}/{:.0f} kbit/s{}", config.nominal_bitrate_bit_per_s / 1e3,
                              config.data_bitrate_bit_per_s / 1e3, config.bit_rate_switch ? "" : " (no BRS)")
                : fmt::format("CAN classic {:.0f} kbit/s", config.nominal_bitrate_bit_per_s / 1e3);
  return fmt::format(
      "{}, {}-bit IDs, {} DOF at {:g} Hz: {} frame(s)/cycle/direction, {} data bytes, {} bits on the wire "
      "(worst-case stuffing; minimum for the {}-bit payload {} bits, overhead {:.3f}x), {:.1f} us/direction, "
      "bus load {:.1f} % both directions (limit {:.1f} %)",
      bus, config.extended_id ? 29 : 11, load.dof, rate_hz, load.frames_per_cycle, load.data_bytes_per_cycle,
      load.wire_bits_per_cycle, load.payload_bits, load.minimum_bits_per_cycle, load.overhead,
      load.wire_time_per_cycle_s * 1e6, load.load * 100.0, config.max_bus_load * 100.0);
}

proto::can::BusLoad CheckCanBusBudget(const CanLinkConfig& config, double rate_hz) {
  const proto::can::CanWireFormat format = WireFormatOf(config);
  const proto::can::FormatStatus status = proto::can::CheckFormat(format);
  if (status != proto::can::FormatStatus::kOk) {
    throw Error(fmt::format("CAN link: {} (dof {}, master->slave base 0x{:X}, slave->master base 0x{:X}, {}-bit)",
                            proto::can::ToString(status), config.dof, config.master_to_slave_base_id,
                            config.slave_to_master_base_id, config.extended_id ? 29 : 11));
  }
  if (!(config.nominal_bitrate_bit_per_s > 0) || !(config.data_bitrate_bit_per_s > 0)) {
    throw Error("CAN link: nominal_bitrate_bit_per_s and data_bitrate_bit_per_s must be > 0");
  }
  if (!(config.max_bus_load > 0.0 && config.max_bus_load <= 1.0)) {
    throw Error(fmt::format("CAN link: max_bus_load must be in (0, 1], got {}", config.max_bus_load));
  }
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) throw Error("CAN link: loop rate must be > 0 Hz");
  const proto::can::BusLoad load = proto::can::ComputeBusLoad(format, BitratesOf(config), rate_hz);
  if (load.load > config.max_bus_load) {
    throw Error("CAN bus load too high: " + FormatBusLoad(load, config, rate_hz) +
                ". Lower the rate or the DOF count, raise the bit rate, enable CAN FD, or raise max_bus_load.");
  }
  return load;
}

}  // namespace teleop::transport
