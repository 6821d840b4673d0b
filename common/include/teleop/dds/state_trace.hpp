#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "teleop/dds/bridge_sample.hpp"
#include "teleop/types.hpp"

namespace teleop::dds {

/// The traces of one State sample as teleop-supervise's dashboard plots them (docs/dds.md, "The dashboard"): what
/// the State carries of the devices and the link, copied out of the DDS sample by dds::Supervisor for every sample
/// taken (Supervisor::Observer::on_state). Plain data; the first min(`dof`, kStateAxes) entries of each array are
/// valid, the rest 0.
struct StateTrace {
  using Axes = std::array<double, kStateAxes>;  ///< What the State carries (the first kStateAxes of the DOF).
  using Joints = std::array<double, kMaxDof>;   ///< The State's joint sequences (bounded by teleop::kMaxDof).

  std::string pair;
  std::string role;
  std::uint64_t cycle = 0;
  double time_s = 0.0;  ///< The process's loop time (since its first cycle).
  Engagement engagement = Engagement::kWaiting;
  std::uint32_t device_faults = 0;
  std::uint8_t dof = 0;
  Axes position_m{};
  Axes peer_position_m{};  ///< As received (peer frame, before scaling).
  Axes force_sensor_N{};
  Axes command_N{};
  double fixture_penetration_m = 0.0;
  double tracking_error_m = 0.0;
  double rtt_ms = 0.0;                     ///< NaN when unknown.
  double fixture_stiffness_N_per_m = 0.0;  ///< The fixture stiffness in use (0: no fixture, or turned off).
  /// The fixture's predicted stability limit at the device's configuration (an arm's run-time limit); NaN when the
  /// process computes none (then the dashboard draws no limit).
  double fixture_limit_N_per_m = std::numeric_limits<double>::quiet_NaN();
  std::uint8_t joints = 0;      ///< A device made of joints: the first `joints` entries below are valid; 0 otherwise.
  Joints joint_position_rad{};  ///< rad (m for a prismatic joint).
  Joints joint_torque_Nm{};     ///< What each joint's actuator reports (N·m; N for a prismatic joint).
  /// The clutch: true while any source holds it (State `clutch` ≠ 0). Dds::Supervisor always fills it; a trace
  /// without one (a test's) leaves it empty, and the dashboard then shows no clutch field.
  std::optional<bool> clutched;
};

}  // namespace teleop::dds
