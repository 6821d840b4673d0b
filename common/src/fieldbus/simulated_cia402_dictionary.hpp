#pragma once

// Private to the simulated CiA 402 drive (simulated_cia402_drive.cpp: the joint, NMT, SYNC and PDOs;
// simulated_cia402_sdo_server.cpp: the SDO server and the object dictionary's access): the communication objects the
// client configures, with their power-on values.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <initializer_list>

#include "teleop/fieldbus/canopen_frames.hpp"
#include "teleop/fieldbus/canopen_pdo.hpp"
#include "teleop/fieldbus/cia402_state_machine.hpp"
#include "teleop/fieldbus/simulated_cia402_drive.hpp"

namespace teleop::fieldbus::simulated {

using canopen::PdoEntry;
using canopen::PdoMapping;
namespace obj = cia402::obj;

inline PdoMapping Mapping(int number, std::initializer_list<PdoEntry> entries) {
  PdoMapping m{};
  m.number = number;
  m.transmission_type = 1;
  for (const PdoEntry& e : entries) m.entries[static_cast<std::size_t>(m.entry_count++)] = e;
  return m;
}

inline std::int32_t RoundToI32(double x) noexcept {
  if (!std::isfinite(x)) return 0;
  return static_cast<std::int32_t>(std::clamp(std::llround(x), -2147483647LL, 2147483647LL));
}

}  // namespace teleop::fieldbus::simulated

namespace teleop::fieldbus {

/// The communication objects the client configures (CiA 301 0x1000..0x1FFF), with their power-on values.
struct SimulatedCia402Drive::Dictionary {
  std::array<canopen::PdoMapping, 4> rpdo{};
  std::array<canopen::PdoMapping, 4> tpdo{};
  std::array<bool, 4> rpdo_valid{};
  std::array<bool, 4> tpdo_valid{};
  std::array<std::uint32_t, 4> rpdo_cob{};
  std::array<std::uint32_t, 4> tpdo_cob{};
  std::array<int, 4> tpdo_sync_count{};
  std::uint32_t sync_cob = canopen::cob::kSync;
  std::uint32_t cycle_period_us = 0;
  std::uint32_t consumer_heartbeat = 0;  // node << 16 | ms
  std::uint16_t producer_heartbeat_ms = 0;
  std::int16_t quick_stop_option = 2;
  std::int16_t fault_reaction_option = 2;
  std::uint16_t max_torque = 1000;
  std::int16_t halt_option = 1;
  std::uint32_t profile_deceleration = 0;     // velocity units per s
  std::uint32_t quick_stop_deceleration = 0;  // velocity units per s

  void Reset(const SimulatedCia402DriveConfig& c) {
    // A factory mapping unlike the client's (statusword alone in TPDO1, position alone in TPDO2, no torque in
    // RPDO1): a client that does not write its own mapping misreads nothing, it is refused on length.
    rpdo = {simulated::Mapping(1, {{cia402::obj::kControlword, 0, 16}}),
            simulated::Mapping(2, {{cia402::obj::kControlword, 0, 16}, {cia402::obj::kTargetTorque, 0, 16}}),
            simulated::Mapping(3, {}), simulated::Mapping(4, {})};
    tpdo = {simulated::Mapping(1, {{cia402::obj::kStatusword, 0, 16}}),
            simulated::Mapping(2, {{cia402::obj::kPositionActual, 0, 32}}), simulated::Mapping(3, {}),
            simulated::Mapping(4, {})};
    for (int n = 0; n < 4; ++n) {
      const auto i = static_cast<std::size_t>(n);
      rpdo_valid[i] = n < 2;
      tpdo_valid[i] = n < 2;
      rpdo_cob[i] = canopen::cob::DefaultRpdo(n + 1, c.node_id);
      tpdo_cob[i] = canopen::cob::DefaultTpdo(n + 1, c.node_id);
      tpdo_sync_count[i] = 0;
    }
    sync_cob = canopen::cob::kSync;
    cycle_period_us = 0;
    consumer_heartbeat = 0;
    producer_heartbeat_ms = c.heartbeat_period_ms;
    halt_option = 1;
    profile_deceleration =
        static_cast<std::uint32_t>(std::llround(c.profile_deceleration_rad_per_s2 / c.velocity_rad_per_s_per_unit));
    quick_stop_deceleration =
        static_cast<std::uint32_t>(std::llround(c.quick_stop_deceleration_rad_per_s2 / c.velocity_rad_per_s_per_unit));
  }
};

}  // namespace teleop::fieldbus
