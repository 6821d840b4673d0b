#pragma once

#include <atomic>
#include <memory>

#include "teleop/config/process_config.hpp"
#include "teleop/control/three_channel_law.hpp"
#include "teleop/device/device.hpp"
#include "teleop/node/run_summary.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::node {

/// One side of the teleoperator: device → law → link, every cycle, on a periodic real-time loop. teleop-master
/// and teleop-slave are this class with a different config. Everything is allocated in the constructor; the
/// cycle allocates nothing, takes no lock and does no I/O (telemetry and events leave through lock-free rings).
class TeleopNode {
 public:
  /// Takes ownership of an opened device and link (so tests can pass doubles). Throws teleop::Error when the
  /// config and the device disagree (DOF, capabilities).
  TeleopNode(const config::ProcessConfig& config, std::unique_ptr<device::Device> device,
             std::unique_ptr<transport::Link> link);
  ~TeleopNode();
  TeleopNode(const TeleopNode&) = delete;
  TeleopNode& operator=(const TeleopNode&) = delete;

  /// Runs until Stop(), the configured duration, or the peer's clean shutdown; returns the summary.
  RunSummary Run();
  /// Async-signal-safe.
  void Stop() noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The whole process: command line (CLI11), config, device, link, signals, summary. `teleop-master` and
/// `teleop-slave` call this with their role; the config's role must match.
int ProcessMain(int argc, char** argv, Role role);

}  // namespace teleop::node
