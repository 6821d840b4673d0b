#pragma once

#include <cstdint>
#include <string>

namespace teleop::transport {

/// Which medium carries the CAN frames.
enum class CanMedium : std::uint8_t {
  kSocketCan,    ///< A Linux SocketCAN interface (transport "can"): can0, vcan0, ...
  kEmulatedBus,  ///< The teleop-canbus daemon on UDP (transport "emulated-can"), for hosts without CAN.
};

/// Configuration of a CAN link (docs/can.md). Both processes must use the same values except `medium` details.
struct CanLinkConfig {
  CanMedium medium = CanMedium::kSocketCan;
  std::string interface_name = "can0";             ///< SocketCAN interface.
  bool fd = false;                                 ///< CAN FD: one frame per cycle; needs an FD interface (MTU 72).
  bool bit_rate_switch = true;                     ///< FD data phase at data_bitrate_bit_per_s.
  double nominal_bitrate_bit_per_s = 1'000'000.0;  ///< The bus's (arbitration) bit rate, as set with `ip link`.
  double data_bitrate_bit_per_s = 5'000'000.0;     ///< FD data-phase bit rate (with bit_rate_switch).
  bool extended_id = false;                        ///< 29-bit identifiers.
  std::uint32_t master_to_slave_base_id = 0x100;   ///< Master's frames use base .. base + 4.
  std::uint32_t slave_to_master_base_id = 0x180;   ///< Slave's frames use base .. base + 4.
  int dof = 1;                                     ///< DOF per sample (the process's dof; both ends equal).
  double max_bus_load = 0.70;                      ///< Refuse to start above this fraction of bus time (0..1].
  std::string emulated_bus_host = "127.0.0.1";     ///< teleop-canbus address (kEmulatedBus).
  std::uint16_t emulated_bus_port = 47300;         ///< teleop-canbus UDP port (kEmulatedBus).
  double connect_timeout_ms = 1000.0;              ///< How long to wait for teleop-canbus to answer at start-up.
  std::string log_path;  ///< Non-empty: a candump -L log of this node's frames (CandumpLogPort).
};

}  // namespace teleop::transport
