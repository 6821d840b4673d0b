#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>

namespace teleop::fieldbus {

/// Where a fieldbus client gets its time from, and how it waits during set-up. The defaults are the steady clock
/// and a short sleep; a host test passes a manual clock and a wait that advances it and steps the simulated drive,
/// so the whole bring-up runs deterministically in one thread. `now_ns` is also called from the real-time cycle
/// (it must not allocate or block); `wait_ns` is called only at set-up (configure/activate/deactivate).
struct Timebase {
  std::function<std::uint64_t()> now_ns;       ///< Monotonic, non-decreasing, ns.
  std::function<void(std::uint64_t)> wait_ns;  ///< Wait about this long (set-up only).

  /// steady_clock and std::this_thread::sleep_for.
  static Timebase Steady();
};

/// A duration in ms (config) as ns of the Timebase clock; negative and NaN give 0.
inline std::uint64_t MsToNs(double ms) noexcept {
  return ms > 0.0 ? static_cast<std::uint64_t>(std::llround(ms * 1e6)) : 0u;
}

}  // namespace teleop::fieldbus
