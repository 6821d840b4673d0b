#pragma once

// TeleopNode's state: the stages, the sinks, the command queue. Private to the node: teleop_node.cpp (the
// lifecycle, the cycle, the summary) and command_handlers.cpp (the Request* handlers) share it.

#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "change_ramp.hpp"
#include "command_queue.hpp"
#include "coupling.hpp"
#include "peer_tracker.hpp"
#include "recorder.hpp"
#include "sinks.hpp"
#include "teleop/device/bus_exchange.hpp"
#include "teleop/node/event_log.hpp"
#include "teleop/node/reading_check.hpp"
#include "teleop/node/teleop_node.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "transmitter.hpp"

namespace teleop::node {

struct TeleopNode::Impl {
  enum class Phase : std::uint8_t { kUnconfigured, kConfigured, kActive, kInactive };

  Impl(const config::ProcessConfig& cfg, std::unique_ptr<device::Device> dev, std::unique_ptr<transport::Link> lnk)
      : config(cfg),
        device(std::move(dev)),
        exchange(device ? device::ExchangeOf(*device) : nullptr),
        link(std::move(lnk)),
        loop(cfg.loop),
        events(1024),
        commands(cfg.dof) {
    events.SetDevice(device.get());  // declared before `events`: outlives its thread
  }
  ~Impl() { DeactivateDevice(); }

  void Configure();
  void ActivateDevice();
  void DeactivateDevice() noexcept;
  void Cycle(std::uint64_t cycle, double period_s, std::int64_t now_ns) noexcept;
  /// Stretches a stiffness or gain change's ramp to the one that keeps its own force change within
  /// engagement.max_force_rate_N_per_s at this cycle's position (change_ramp.hpp): a ramp of 0 is not a force step.
  void BoundChangeRamps(Changes& changes, const PeerView& view) noexcept;
  /// What the law's gains multiply now, from this cycle's reading and peer (into `signals`, preallocated).
  const GainSignals& Signals(const PeerView& view) noexcept;
  Sensed Sense(double period_s) noexcept;
  void Actuate(const Applied& applied, double period_s) noexcept;
  CycleFacts Facts(std::uint64_t cycle, double t_s, std::uint8_t flags, std::int64_t data_age_ns,
                   std::int64_t cycle_start_mono_ns, bool usable) const noexcept;
  RunSummary Summarize(double wall_s);
  void SummarizeLoop(RunSummary& summary, double wall_s) const;
  void SummarizeLink(RunSummary& summary) const;
  void SummarizeCoupling(RunSummary& summary) const;

  config::ProcessConfig config;
  std::unique_ptr<device::Device> device;
  device::BusExchange* exchange = nullptr;  ///< The device's bus exchange (a fieldbus backend), else null.
  std::unique_ptr<transport::Link> link;
  runtime::PeriodicLoop loop;
  SinkSet sinks;                                        ///< Declared before `events`: outlives its observer role.
  std::vector<std::unique_ptr<CycleSink>> added_sinks;  ///< TeleopNode::AddSink, after the node's own.
  EventLog events;
  NodeClock clock;
  Phase phase = Phase::kUnconfigured;

  // The stages (built by Configure: they need the device's capabilities).
  std::unique_ptr<ReadingCheck> reading_check;
  std::unique_ptr<PeerTracker> peer;
  std::unique_ptr<Coupling> coupling;
  std::unique_ptr<Transmitter> transmitter;
  std::unique_ptr<Recorder> recorder;

  // Preallocated values of the cycle.
  device::Reading reading;
  std::uint64_t stepped_cycles = 0;
  std::int64_t start_ns = 0;
  std::atomic<bool> stop_on_peer_shutdown{false};
  std::atomic<bool> stop_requested{false};
  /// TeleopNode::peer_data_age_s: the last cycle's sender data age (ns; -1: none), for any thread.
  std::atomic<std::int64_t> peer_sender_age_ns{-1};
  static_assert(std::atomic<std::int64_t>::is_always_lock_free, "read by other threads, wait-free");
  std::atomic<bool> command_clutch{false};  ///< TeleopNode::SetClutch (any thread) → the cycle.
  /// TeleopNode::SetFixtureLimit (any thread) → the cycle's telemetry; NaN: none.
  std::atomic<double> fixture_limit_N_per_m{std::numeric_limits<double>::quiet_NaN()};
  static_assert(std::atomic<double>::is_always_lock_free, "stored by another thread, read by the cycle, wait-free");

  /// Run-time commands (TeleopNode::Request*, command_handlers.cpp) to the cycle. Producers are serialised by
  /// command_mutex, which also guards what follows it.
  CommandQueue commands;
  std::mutex command_mutex;
  config::ProcessConfig check_base;  ///< What the next check starts from: accepted changes applied.
  double fixture_on_N_per_m = 0.0;   ///< What `fixture on` restores.
  /// The node's own watchers' bounds on the fixture stiffness (RequestFixtureStiffnessWithinConfigured), by
  /// FixtureBound; +inf: none. The fixture ramps to min(the accepted stiffness, every bound).
  std::array<double, 2> fixture_bounds{std::numeric_limits<double>::infinity(),
                                       std::numeric_limits<double>::infinity()};
  GainSignals signals;
  DofVector ramp_position_m;  ///< The law's position for the ramp floor (preallocated).
  std::string session_config_path, session_config_yaml, session_startup_analysis;  ///< SetSessionRecord
  bool published = false;
};

}  // namespace teleop::node
