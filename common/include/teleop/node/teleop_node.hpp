#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "teleop/config/process_config.hpp"
#include "teleop/control/passivity_controller.hpp"
#include "teleop/control/three_channel_law.hpp"
#include "teleop/device/device.hpp"
#include "teleop/node/cycle_sink.hpp"
#include "teleop/node/engagement.hpp"
#include "teleop/node/run_summary.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::node {

/// One side of the teleoperator: device → law → link, every cycle, on a periodic real-time loop. teleop-master
/// and teleop-slave are this class with a different config. Everything is allocated before the first cycle; the
/// cycle allocates nothing, takes no lock and does no I/O (telemetry and events leave through lock-free rings).
///
/// The cycle is a pipeline of values (docs/architecture.md, "The cycle"): Sense (Device::Read and the node's
/// reading checks → Sensed), the peer tracker (receive, watchdog, round trip, data age → PeerView), the coupling
/// (engagement, aligner, the law, force-rate limiter, safe reaction, passivity → Applied, the command actually
/// applied), Actuate (Device::Write of it, or Device::SetSafe; then Device::Update), Transmit (this cycle's
/// sample), Record (statistics, events, and the cycle's record to every sink: telemetry CSV, fault ring, DDS).
///
/// Lifecycle, after ros2_control: unconfigured → Configure() → configured → Activate() → active → Deactivate().
class TeleopNode {
 public:
  /// Asks the constructor to leave the node unconfigured: the caller runs Configure() and Activate().
  struct Unconfigured {};

  /// Takes ownership of a device (constructed, not yet configured) and an opened link (so tests can pass
  /// doubles), then Configure() and activates the device without the real-time settings (Run() applies them to its
  /// own thread, as before). Throws teleop::Error naming the config key or the device's reason when this fails.
  TeleopNode(const config::ProcessConfig& config, std::unique_ptr<device::Device> device,
             std::unique_ptr<transport::Link> link);
  /// The same, unconfigured: nothing is opened or checked yet.
  TeleopNode(const config::ProcessConfig& config, std::unique_ptr<device::Device> device,
             std::unique_ptr<transport::Link> link, Unconfigured);
  /// Deactivates the device if Run() or Deactivate() has not.
  ~TeleopNode();
  TeleopNode(const TeleopNode&) = delete;
  TeleopNode& operator=(const TeleopNode&) = delete;

  /// Adds an output (teleop/node/cycle_sink.hpp) after the node's own (fault ring, telemetry CSV, DDS). Only while
  /// unconfigured: the event log's thread reads the sinks from Configure() on.
  void AddSink(std::unique_ptr<CycleSink> sink);
  /// Configures the device (opens its bus), checks that it can render this config's law, fixture and reaction
  /// (config::RequireRenderable, safety.reaction), and opens the outputs (telemetry CSV, fault records, DDS).
  /// Throws teleop::Error; the device is never activated by it.
  void Configure();
  /// On the thread that will call Run(): applies the real-time settings (realtime.cpu affinity, SCHED_FIFO,
  /// mlockall) and checks that they hold, then activates the device. A refused setting throws before the device is
  /// activated. Requires Configure().
  void Activate();
  /// Puts the device into its inactive state (Device::Deactivate). Idempotent; noexcept.
  void Deactivate() noexcept;

  /// Runs until Stop(), the configured duration, or the peer's clean shutdown; deactivates the device and returns
  /// the summary.
  RunSummary Run();
  /// Async-signal-safe.
  void Stop() noexcept;

  /// One cycle outside the periodic loop, for tests and lock-step simulations that step both sides in one thread.
  /// `cycle` counts from 0. Same code as a cycle of Run(): allocation-free, never throws. Does nothing unless active.
  void Step(std::uint64_t cycle, double period_s) noexcept;
  /// The same on a clock the caller drives (CLOCK_MONOTONIC-like ns): lock-step simulations are deterministic,
  /// watchdog and engagement included.
  void Step(std::uint64_t cycle, double period_s, std::int64_t now_ns) noexcept;
  /// After Step()s: deactivates the device, writes pending fault records, stops the writers and returns the summary.
  RunSummary Finish();
  /// The session record's parts (deploy/teleop-session) the summary carries, set before Run(): what ran, as read at
  /// start-up. They are in the summary every sink publishes (the DDS run summary equals --summary-json).
  void SetSessionRecord(std::string config_path, std::string config_yaml, std::string startup_analysis);
  /// Where the node is in coupling to its peer (after the last cycle).
  EngagementState engagement() const noexcept;
  /// The command channel's clutch (docs/clutch.md): pressed until SetClutch(false).
  /// Any thread; the next cycle reads it.
  void SetClutch(bool pressed) noexcept;
  /// Any clutch (the device's, the command's, the peer's) held in the last cycle.
  bool clutched() const noexcept;
  /// A master's re-index offset on `axis` (m, local frame): added to its position before the law and the wire.
  double index_offset_m(int axis) const noexcept;
  /// Largest |Δ coupling force| per second while clutched (bounded by engagement.max_force_rate_N_per_s).
  double max_clutch_force_rate_N_per_s() const noexcept;

  /// A run-time change (fixture stiffness, gain, plane) and its verdict.
  struct FixtureChange {
    bool accepted = false;
    double requested_N_per_m = 0.0;
    double limit_N_per_m = 0.0;  ///< The predicted limit (analysis::StabilityLimit); 0 when not analysed.
    std::string message;         ///< Why refused, or the check's pass line.
  };
  /// Runs the start-up stability check (config::CheckProcessStability) with `stiffness_N_per_m` on the CALLER's
  /// thread (never the cycle's) and refuses an unstable value with the predicted limit, a value that is not finite
  /// or negative, and any value when the check does not apply to this device. An accepted change is handed to the
  /// cycle through a wait-free ring (SPSC) and ramps linearly over `ramp_s`, or over the shortest ramp that keeps
  /// the force change within engagement.max_force_rate_N_per_s at the position of the cycle that takes it when that
  /// is longer (a ramp of 0 is never a force step; docs/clutch.md); the cycle logs the outcome as an event
  /// (command_accepted with the stiffness, command_refused with the limit). Serialised between callers.
  /// The stiffness ramps to min(stiffness_N_per_m, every RequestFixtureStiffnessWithinConfigured bound).
  FixtureChange RequestFixtureStiffness(double stiffness_N_per_m, double ramp_s);
  /// The node's own watchers that bound the fixture stiffness at run time.
  enum class FixtureBound : std::uint8_t {
    kDelayRecheck = 0,        ///< config::DelayRecheck: the limit at the measured delay.
    kConfigurationLimit = 1,  ///< config::ConfigurationLimit: the limit at the device's configuration.
  };
  /// A run-time bound on the fixture stiffness from one of the node's watchers (never the operator): `source`'s
  /// bound becomes `bound_N_per_m` (+inf lifts it) and the fixture ramps over `ramp_s` (or the force-rate bound's
  /// longer ramp, as for RequestFixtureStiffness) to min(the accepted stiffness, every source's bound): never above
  /// the stiffness configured or accepted by the operator's commands, and each watcher's restoring its bound leaves
  /// the other's in force. Not checked again (a lower stiffness than an accepted one); a NaN or negative bound is
  /// refused. Logged as command_accepted with the stiffness it ramps to (the caller logs its own event).
  FixtureChange RequestFixtureStiffnessWithinConfigured(FixtureBound source, double bound_N_per_m, double ramp_s);
  /// The fixture's predicted limit at the device's current configuration (N/m; NaN: none), for the telemetry
  /// column fixture_limit_N_per_m. Any thread; wait-free (an atomic the cycle reads).
  void SetFixtureLimit(double limit_N_per_m) noexcept;
  /// Fixture off: ramps the stiffness to 0 (checked like any change: a pair unstable without its fixture is
  /// refused). On: ramps back to the last accepted non-zero stiffness (the configured one at first), checked.
  FixtureChange RequestFixtureEnabled(bool on, double ramp_s);
  /// The fixture stiffness the law uses now (N/m).
  double fixture_stiffness_N_per_m() const noexcept;
  /// The stiffness configured or last accepted from RequestFixtureStiffness (N/m): what the watchers' bounds may not
  /// raise the fixture above. Takes the command lock: not for the cycle.
  double accepted_fixture_stiffness_N_per_m() const;

  /// A run-time change of one law gain (`axis` -1: every axis), checked like a stiffness change: the stability check
  /// with the changed gain (the peer keeps the gains the start-up check assumed for it) and the render check
  /// (config::RequireRenderable) on the CALLER's thread; an unstable one is refused with the predicted fixture limit
  /// under the changed gain. A value that is not finite, negative (K_p, K_d, K_v), a K_f on the slave or an axis out
  /// of range is refused. An accepted change ramps linearly over `ramp_s`, at least as long as the force-rate bound
  /// needs (as for the stiffness). Events: gain_accepted / gain_refused.
  FixtureChange RequestGain(GainName name, int axis, double value, double ramp_s);
  /// Moves fixture plane 0 to (`normal`, normalised; `offset_m`) at a bounded rate: the cycle slews the offset at
  /// `rate_m_per_s` (<= 0: fixture.max_offset_rate_m_per_s; above it: refused) and the normal at
  /// fixture.max_normal_rate_rad_per_s scaled by the same fraction. Refused: no fixture plane, a normal of the wrong
  /// size, zero or not finite, a non-finite offset or one beyond the workspace (|offset| > sqrt(dof) ·
  /// safety.max_abs_position_m; 1000 m when that is 0), a 1-DOF normal that flips sign. A move that changes which axes
  /// the normal has a component on runs the stability check first (the plane's position does not enter it, eq. 7).
  /// Events: plane_accepted / plane_refused.
  FixtureChange RequestFixturePlane(const DofVector& normal, double offset_m, double rate_m_per_s);
  /// An outcome of the command channel that changes nothing (a malformed command, a refused peer, a clutch
  /// command) as an event: handed to the cycle with the changes, which logs it (DDS events topic too). Any thread;
  /// when the hand-over ring (64) is full the event is dropped and counted.
  void RecordCommandEvent(Event::Kind kind, double value, std::uint16_t detail = 0) noexcept;
  /// Switches the time-domain passivity controller to `mode` at run time (the delay re-check's `on_unstable:
  /// passivity`, docs/stability.md): the cycle applies it at its drain point (PassivityController::SwitchMode: passive
  /// from the switch on) and logs the event `kind`/`value`/`detail`. Any thread. False when the hand-over ring was
  /// full: nothing changes.
  bool RequestPassivityMode(control::PassivityMode mode, Event::Kind kind, double value, std::uint16_t detail) noexcept;
  /// Command outcomes not handed to the cycle because its ring was full.
  std::uint64_t command_events_dropped() const noexcept;
  /// The sender data age of the peer's sample the law used in the last cycle (s): that cycle's start − the peer's
  /// send time on our clock (the clock offset from the round trip; docs/performance.md, "Round trip and data age"),
  /// i.e. the link's one-way delay plus the wait for the cycle. < 0 when the last cycle used no peer sample or no
  /// clock offset is known yet. Any thread: the cycle stores it in an atomic (wait-free), the run-time delay re-check
  /// reads it (docs/stability.md, "Run-time re-check").
  double peer_data_age_s() const noexcept;
  /// The process's DOF (the config's; any thread).
  int dof() const noexcept;
  /// The fixture plane the law uses now (after the last cycle; on the cycle's thread or between Step()s); a default
  /// plane when `index` is not configured.
  control::FixturePlane fixture_plane(int index) const noexcept;
  /// Largest one-cycle change of a moved plane's offset (m) and normal (rad) so far.
  double max_plane_offset_step_m() const noexcept;
  double max_plane_normal_step_rad() const noexcept;
  /// A gain the law uses now.
  double gain(GainName name, int axis) const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace teleop::node
