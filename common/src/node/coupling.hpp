#pragma once

// Stage 3 of the cycle (docs/architecture.md, "The cycle"): from what the device sensed, what the peer tracker saw
// and the cycle's changes to the command actually applied. Private to the node. Its own stages live in coupling/:
// clutch → engagement → setpoints → law input → law → shaper → passivity.

#include <cstdint>

#include "coupling/changes.hpp"
#include "coupling/clutch.hpp"
#include "coupling/law_input.hpp"
#include "coupling/passivity_port.hpp"
#include "coupling/setpoints.hpp"
#include "coupling/shaper.hpp"
#include "peer_tracker.hpp"
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

/// The coupling's output, a value: the command the device gets this cycle (after the aligning limiter, the
/// safe-state reaction, the device-fault replacement and the passivity controller, in that order), the device
/// command made of it, and what the wire sample and the record need.
struct Applied {
  control::ThreeChannelLaw::Output law;       ///< The law's own output (velocity, fixture, status, penetration).
  double fixture_stiffness_N_per_m = 0.0;     ///< The fixture stiffness the law used (a ramp's value this cycle).
  control::ThreeChannelLaw::Output command;   ///< Applied: command_N (0 in the safe state), its fixture share.
  device::Command device_command;             ///< What Device::Write gets (not filled when `safe`).
  DofVector damping_Ns_per_m;                 ///< The passivity controller's α this cycle.
  DofVector peer_local_m;                     ///< The peer's position in the local frame.
  control::ThreeChannelLaw::Input law_input;  ///< What the law saw (virtual peer included).
  EngagementMachine::Transition transition;
  EngagementState engagement = EngagementState::kDisengaged;  ///< After this cycle's transitions.
  Reaction reaction = Reaction::kZeroForce;                   ///< safety.reaction (what "not coupled" does).
  PortEnergies passivity;                                     ///< The port's energies after this step.
  control::PassivityMode passivity_mode = control::PassivityMode::kOff;
  bool safe = false;                ///< Device::SetSafe instead of Write (device fault, brake).
  bool nonfinite = false;           ///< The law saw NaN/inf.
  std::uint8_t clutch_sources = 0;  ///< ClutchSource bits pressed this cycle (0: not clutched).
  bool clutch_flag = false;         ///< kFlagClutched of this cycle's sample (docs/clutch.md).
};

/// Engagement, aligner, force-rate limiter, safe reaction and time-domain passivity around the three-channel law,
/// as a short list of stages (coupling/), each Config + State + Step. The passivity port integrates the command
/// actually applied (docs/stability.md). Allocation-free and noexcept in Step.
class Coupling {
 public:
  /// The config sections the coupling uses.
  struct Config {
    Role role = Role::kMaster;
    int dof = 1;
    control::ThreeChannelLaw::Config law;
    EngagementConfig engagement;
    SafetyConfig safety;
    control::PassivityController::Config passivity;
    bool measures_velocity = false;
    bool can_push = false;  ///< The device renders active force: a clutched slave holds (else: its reaction).
  };
  /// What crosses from one cycle to the next outside the stages.
  struct State {
    DofVector last_velocity;  ///< The law's velocity of the previous cycle (for the reactions' latch).
  };

  Coupling(const Config& config, EventLog& events);

  Applied Step(const Sensed& sensed, const PeerView& peer, const Changes& changes, std::uint64_t cycle, double t_s,
               double period_s) noexcept;

  const EngagementMachine& engagement() const noexcept { return engagement_; }
  const control::ThreeChannelLaw& law() const noexcept { return law_; }
  const control::PassivityController& passivity() const noexcept { return passivity_.controller(); }
  const Clutch::State& clutch_state() const noexcept { return clutch_.state(); }
  const Setpoints::State& setpoints_state() const noexcept { return setpoints_.state(); }
  const LawInputStage::State& law_input_state() const noexcept { return law_input_.state(); }
  const Shaper::State& shaper_state() const noexcept { return shaper_.state(); }
  const PassivityPort::State& passivity_state() const noexcept { return passivity_.state(); }
  const State& state() const noexcept { return state_; }

 private:
  Clutch::Output StepClutch(const Sensed& sensed, const PeerView& peer, const Changes& changes,
                            std::uint64_t cycle) noexcept;
  void StepSetpoints(const Changes& changes, double period_s) noexcept;
  void PushEngagementEvents(const EngagementMachine::Transition& tr, std::uint64_t cycle) noexcept;
  CouplingPath PathOf(std::uint32_t local_faults, bool nonfinite, bool clutch_path) const noexcept;

  Config config_;
  EventLog& events_;
  Clutch clutch_;
  EngagementMachine engagement_;
  Setpoints setpoints_;
  LawInputStage law_input_;
  control::ThreeChannelLaw law_;
  Reactions reactions_;
  Shaper shaper_;
  PassivityPort passivity_;
  State state_;
};

}  // namespace teleop::node
