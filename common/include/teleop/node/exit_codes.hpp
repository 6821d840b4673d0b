#pragma once

#include "teleop/node/run_summary.hpp"

namespace teleop::node {

/// Exit status of teleop-master and teleop-slave. The systemd units (deploy/systemd/) restart a process after every
/// status except those that need a person: their RestartPreventExitStatus= lists kExitConfigError,
/// kExitUnexpectedError and kExitFaulted (tests/deploy/systemd_units_test.py reads this header to check that).
inline constexpr int kExitOk = 0;  ///< Clean stop: duration, signal, or the peer's shutdown.
/// Set-up failed: invalid config, start refused by the stability check, device or link cannot be opened. The same
/// config fails the same way again: never restarted.
inline constexpr int kExitConfigError = 2;
inline constexpr int kExitUnexpectedError = 3;  ///< Anything else that escaped (a bug): never restarted.
/// The run ended normally but saw a device fault or a non-finite input (the process held its safe state). Latched:
/// a unit must not restart into it silently; a person reads the summary and clears the cause first.
inline constexpr int kExitFaulted = 4;

/// The run ended (duration, signal, --connect-timeout) without a usable sample of the peer ever arriving: no peer,
/// a wrong address, another key, another protocol version or security mode. The summary's "connection" line says
/// which. A unit restarts after it (the peer may come up later); a person reads the status lines.
inline constexpr int kExitNeverConnected = 5;

/// kExitFaulted when the run saw a device fault or a non-finite input, else kExitNeverConnected when the peer never
/// connected, else kExitOk.
[[nodiscard]] inline int ExitCodeFor(const RunSummary& summary) noexcept {
  if (summary.device_fault_cycles > 0 || summary.nonfinite_inputs > 0) return kExitFaulted;
  return summary.connected ? kExitOk : kExitNeverConnected;
}

}  // namespace teleop::node
