#pragma once

#include <atomic>
#include <cstdint>
#include <memory>

#include "teleop/config/process_config.hpp"
#include "teleop/control/three_channel_law.hpp"
#include "teleop/device/device.hpp"
#include "teleop/node/engagement.hpp"
#include "teleop/node/run_summary.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::node {

/// One side of the teleoperator: device → law → link, every cycle, on a periodic real-time loop. teleop-master
/// and teleop-slave are this class with a different config. Everything is allocated in the constructor; the
/// cycle allocates nothing, takes no lock and does no I/O (telemetry and events leave through lock-free rings).
///
/// The cycle's stages, in order: Sense (Device::Read), Receive (drain the link, watchdog), Control (the law),
/// Actuate (Device::Write of the law's Command, or Device::SetSafe on a device fault; then Device::Update),
/// Transmit (this cycle's sample), Record (statistics, events, telemetry).
class TeleopNode {
 public:
  /// Takes ownership of a device (constructed, not yet configured) and an opened link (so tests can pass
  /// doubles). Configures the device, checks that it can render this config's law and fixture
  /// (config::RequireRenderable: DOF, active gains on a device that cannot push, force limits), then activates it.
  /// Throws teleop::Error naming the config key or the device's reason when any of this fails.
  TeleopNode(const config::ProcessConfig& config, std::unique_ptr<device::Device> device,
             std::unique_ptr<transport::Link> link);
  /// Deactivates the device if Run() has not.
  ~TeleopNode();
  TeleopNode(const TeleopNode&) = delete;
  TeleopNode& operator=(const TeleopNode&) = delete;

  /// Runs until Stop(), the configured duration, or the peer's clean shutdown; deactivates the device and returns
  /// the summary.
  RunSummary Run();
  /// Async-signal-safe.
  void Stop() noexcept;

  /// One cycle outside the periodic loop, for tests and lock-step simulations that step both sides in one thread.
  /// `cycle` counts from 0. Same code as a cycle of Run(): allocation-free, never throws.
  void Step(std::uint64_t cycle, double period_s) noexcept;
  /// The same on a clock the caller drives (CLOCK_MONOTONIC-like ns): lock-step simulations are deterministic,
  /// watchdog and engagement included.
  void Step(std::uint64_t cycle, double period_s, std::int64_t now_ns) noexcept;
  /// After Step()s: deactivates the device, writes pending fault records, stops the writers and returns the summary.
  RunSummary Finish();
  /// Where the node is in coupling to its peer (after the last cycle).
  EngagementState engagement() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace teleop::node
