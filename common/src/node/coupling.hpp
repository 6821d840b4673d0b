#pragma once

// Stage 3 of the cycle (docs/architecture.md, "The cycle"): from what the device sensed and what the peer tracker
// saw to the command actually applied. Private to the node.

#include <cstdint>

#include "peer_tracker.hpp"
#include "teleop/config/process_config.hpp"
#include "teleop/control/passivity_controller.hpp"
#include "teleop/control/three_channel_law.hpp"
#include "teleop/device/device.hpp"
#include "teleop/node/engagement.hpp"
#include "teleop/node/event_log.hpp"
#include "teleop/node/safe_reaction.hpp"

namespace teleop::node {

/// Stage 1's output: the device's reading and the faults the node sees in it.
struct Sensed {
  const device::Reading* reading = nullptr;
  std::uint32_t local_faults = 0;  ///< Device fault bits | the node's reading checks (ReadingCheck).
};

/// The coupling's output: the command the device gets this cycle, after the aligning limiter, the safe-state
/// reaction, the device-fault replacement and the passivity controller, in that order.
struct Applied {
  control::ThreeChannelLaw::Output law;      ///< The law's own output (velocity, fixture, status, penetration).
  control::ThreeChannelLaw::Output command;  ///< Applied: command_N (0 in the safe state), its fixture share.
  DofVector damping_Ns_per_m;                ///< The passivity controller's α this cycle.
  DofVector peer_local_m;                    ///< The peer's position in the local frame.
  const control::ThreeChannelLaw::Input* law_input = nullptr;  ///< What the law saw (virtual peer included).
  EngagementMachine::Transition transition;
  EngagementState engagement = EngagementState::kDisengaged;       ///< After this cycle's transitions.
  Reaction reaction = Reaction::kZeroForce;                        ///< safety.reaction (what "not coupled" does).
  const control::PassivityController::State* passivity = nullptr;  ///< The port's energies after this step.
  control::PassivityMode passivity_mode = control::PassivityMode::kOff;
  bool safe = false;                ///< Device::SetSafe instead of Write (device fault, brake).
  bool nonfinite = false;           ///< The law saw NaN/inf.
  std::uint8_t clutch_sources = 0;  ///< ClutchSource bits pressed this cycle (0: not clutched).
  bool clutch_flag = false;         ///< kFlagClutched of this cycle's sample (docs/clutch.md).
};

/// Who holds the clutch (bits of Applied::clutch_sources and of the clutch events' value).
enum ClutchSource : std::uint8_t {
  kClutchDevice = 1u << 0,   ///< device::Reading::clutch_pressed (a pedal or button of the backend).
  kClutchPeer = 1u << 1,     ///< The peer's fresh sample carries kFlagClutched.
  kClutchCommand = 1u << 2,  ///< The command channel (TeleopNode::SetClutch).
};

/// Engagement, aligner, force-rate limiter, safe reaction and time-domain passivity around the three-channel law:
/// Config + State + one Step that returns the command actually applied. The passivity port integrates that
/// command (docs/stability.md). Allocation-free and noexcept in Step.
class Coupling {
 public:
  struct Config {
    config::ProcessConfig process;  ///< law, engagement, safety, passivity, dof.
    bool measures_velocity = false;
    bool can_push = false;  ///< The device renders active force: a clutched slave holds (else: its reaction).
  };
  /// What crosses from one cycle to the next.
  struct State {
    bool aligned_verdict = false;   ///< Aligner reached the peer and the limiter did not clip (for the next Update).
    bool reaction_latched = false;  ///< The reaction holds the state latched at the loss of coupling.
    DofVector last_velocity;        ///< The law's velocity of the previous cycle (for the reaction's latch).
    DofVector last_reference_m;     ///< The coupling reference of the previous cycle (local frame).
    double max_reference_step_m = 0.0;     ///< Largest one-cycle jump of the reference while (re)engaging.
    double max_aligning_force_rate = 0.0;  ///< Largest |Δ coupling force| / period aligning and at engagement.
    std::uint64_t passivity_peer_without_energy = 0;  ///< energy_exchange: peer samples without the block.
    std::uint8_t clutch_sources = 0;                  ///< Of the previous cycle (press/release events on a change).
    bool clutch_latched = false;                      ///< The clutch's hold latched its target at the press.
    bool index_pending = false;          ///< Master: clutched since the last coupling; re-index at the next aligning.
    DofVector index_offset_m;            ///< Master: added to the position before the law and the wire (local frame).
    double max_clutch_force_rate = 0.0;  ///< Largest |Δ coupling force| / period while clutched (N/s).
    std::uint64_t clutch_presses = 0;
    std::uint64_t reindexes = 0;
  };

  Coupling(const Config& config, EventLog& events);

  const Applied& Step(const Sensed& sensed, const PeerView& peer, std::uint64_t cycle, double t_s,
                      double period_s) noexcept;

  const State& state() const noexcept { return state_; }
  const EngagementMachine& engagement() const noexcept { return engagement_; }
  const control::ThreeChannelLaw& law() const noexcept { return law_; }
  const control::PassivityController& passivity() const noexcept { return passivity_; }
  Reaction reaction() const noexcept { return reaction_.reaction(); }
  /// The command channel's clutch (kClutchCommand), read by the next Step. Called on the cycle's thread.
  void SetCommandClutch(bool pressed) noexcept { command_clutch_ = pressed; }
  /// Ramps the fixture's stiffness linearly to `target_N_per_m` over `ramp_s` from the next Step (a change the
  /// stability check accepted). Called on the cycle's thread.
  void RampFixtureStiffness(double target_N_per_m, double ramp_s) noexcept {
    ramp_from_N_per_m_ = law_.fixture().config().stiffness_N_per_m;
    ramp_to_N_per_m_ = target_N_per_m;
    ramp_s_ = ramp_s > 0.0 ? ramp_s : 0.0;
    ramp_elapsed_s_ = 0.0;
    ramping_ = true;
  }
  /// Ramps the law's gains linearly from what they are to these over `ramp_s` from the next Step (a change the
  /// stability check accepted). Called on the cycle's thread.
  void RampGains(const DofVector& kp_N_per_m, const DofVector& kd_Ns_per_m, const DofVector& kv_Ns_per_m,
                 const DofVector& kf, double ramp_s) noexcept;
  /// Slews fixture plane `index` toward (`normal`, unit; `offset_m`) from the next Step: the offset by at most
  /// `offset_rate_m_per_s` · period, the normal (along the great circle) by at most `normal_rate_rad_per_s` · period
  /// per cycle. A later move replaces the target. Called on the cycle's thread.
  void MovePlane(int index, const DofVector& normal, double offset_m, double offset_rate_m_per_s,
                 double normal_rate_rad_per_s) noexcept;
  /// Largest one-cycle change of a moved plane's offset (m) and normal (rad) so far.
  double max_plane_offset_step_m() const noexcept { return max_plane_offset_step_m_; }
  double max_plane_normal_step_rad() const noexcept { return max_plane_normal_step_rad_; }
  bool plane_slewing() const noexcept { return slewing_; }

 private:
  /// Which path chose the command.
  enum class Path : std::uint8_t { kDeviceFault, kNonFinite, kAligning, kEngaged, kReaction, kClutched };

  void Engage(const Sensed& sensed, const PeerView& peer, std::uint64_t cycle, double t_s) noexcept;
  void Reindex(const device::Reading& reading, std::uint64_t cycle) noexcept;
  void ShapeClutched(double t_s, double period_s) noexcept;
  void PrepareInput(const device::Reading& reading, const PeerView& peer, double t_s, double period_s) noexcept;
  void Align(const device::Reading& reading, double t_s, double period_s) noexcept;
  void Shape(Path path, double t_s, double period_s) noexcept;
  void Passivate(Path path, const PeerView& peer, double period_s) noexcept;
  void Track(Path path, double period_s) noexcept;
  Path PathOf(const Sensed& sensed) const noexcept;
  void StepRamps(double period_s) noexcept;
  void StepPlane(double period_s) noexcept;

  Config config_;
  EventLog& events_;
  control::ThreeChannelLaw law_;
  control::PassivityController passivity_;  ///< Off = observe only.
  EngagementMachine engagement_;
  Aligner aligner_;
  ForceRateLimiter limiter_;  ///< The coupling part of the command while aligning; tracks it otherwise.
  SafeReaction reaction_;
  SafeReaction clutch_hold_;  ///< A clutched slave's hold (safety.reaction = hold, whatever the configured one).
  State state_;
  bool command_clutch_ = false;
  std::uint64_t cycle_ = 0;
  bool ramping_ = false;
  double ramp_from_N_per_m_ = 0.0;
  double ramp_to_N_per_m_ = 0.0;
  double ramp_s_ = 0.0;
  double ramp_elapsed_s_ = 0.0;
  bool gains_ramping_ = false;
  double gains_ramp_s_ = 0.0;
  double gains_elapsed_s_ = 0.0;
  DofVector gains_from_[4];  ///< kp, kd, kv, kf at the start of the ramp.
  DofVector gains_to_[4];
  DofVector gains_now_[4];
  bool slewing_ = false;
  int slew_plane_ = 0;
  DofVector slew_normal_;  ///< The target (unit).
  double slew_offset_m_ = 0.0;
  double slew_offset_rate_ = 0.0;
  double slew_normal_rate_ = 0.0;
  DofVector plane_normal_;  ///< Scratch of this cycle's slew step.
  double max_plane_offset_step_m_ = 0.0;
  double max_plane_normal_step_rad_ = 0.0;
  bool clutch_blocked_ = false;  ///< The clutch is this cycle's blocker.
  bool clutch_path_ = false;     ///< ... and the clutch's own command applies (master, or a slave that can push).
  DofVector hold_N_;
  // Preallocated values of this cycle.
  control::ThreeChannelLaw::Input input_;
  control::PassivityController::Input passivity_input_;
  DofVector zero_;
  Applied applied_;
};

}  // namespace teleop::node
