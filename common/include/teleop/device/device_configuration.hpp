#pragma once

// A device whose stability model depends on its configuration (an arm's joint angles; docs/arms.md, "Stability"):
// the cycle publishes its configuration into a wait-free mailbox, and a thread of its own (config::ConfigurationLimit)
// reads it and evaluates the fixture's stability limit there. Fixed capacity: the cycle's copy never allocates.

#include <array>
#include <type_traits>

#include "teleop/runtime/mailbox.hpp"

namespace teleop::device {

/// The most configuration values a device publishes (an arm's joints: device/arm kMaxJoints).
inline constexpr int kMaxConfigurationValues = 8;

/// One configuration as the device read it this cycle: `count` values (rad or m per joint, in the chain's order).
struct DeviceConfiguration {
  int count = 0;  ///< 0: none published yet.
  std::array<double, kMaxConfigurationValues> values{};
};
static_assert(std::is_trivially_copyable_v<DeviceConfiguration>);

/// Single writer (the cycle's Device::Read), single reader (the run-time limit's thread).
using ConfigurationMailbox = runtime::Mailbox<DeviceConfiguration>;

/// How the run-time limit runs for a device (`device.<backend>.runtime_limit`, docs/configuration.md).
struct ConfigurationLimitOptions {
  bool enabled = false;
  double rate_hz = 10.0;  ///< Evaluations per second (each one a limit search, tens of ms).
  /// The fixture is lowered when its stiffness is above (1 − margin) × the limit at the configuration, to that.
  double margin = 0.1;
  /// Raised again (up to the configured stiffness) when (1 − margin) × the limit exceeds the stiffness by this
  /// fraction: (1 − margin) × limit / (1 + hysteresis) is the raised value.
  double hysteresis = 0.05;
  double max_force_rate_N_per_s = 20.0;  ///< The ramp's force rate at max_penetration_m (bounds the ramp time).
  double max_penetration_m = 0.01;       ///< The deepest penetration the ramp's force rate is bounded at.
};

}  // namespace teleop::device
