#pragma once

// The law-input stage of the coupling: what the three-channel law is told this cycle (the peer as received, the
// aligning reference, the reaction's virtual peer, a re-indexed master's offset). Private to the node.

#include <cstdint>

#include "teleop/control/three_channel_law.hpp"
#include "teleop/device/device.hpp"
#include "teleop/node/engagement.hpp"
#include "teleop/node/safe_reaction.hpp"
#include "teleop/proto/sample_message.hpp"

namespace teleop::node {

/// The safe-state reaction and the clutch's hold (safety.reaction = hold, whatever the configured one): latched
/// and given their virtual peer by LawInputStage, asked for their command by Shaper.
struct Reactions {
  SafeReaction reaction;
  SafeReaction clutch_hold;
};

/// Latches the reactions when coupling stops, starts and steps the Aligner, re-indexes a master after a clutch, and
/// fills the law's input. Allocation-free and noexcept in Step.
class LawInputStage {
 public:
  struct Config {
    int dof = 1;
    bool master = false;
    bool measures_velocity = false;
    double peer_position_scale = 1.0;  ///< law.peer_position_scale
    EngagementConfig engagement;       ///< The Aligner's speed, time and tolerance.
  };
  struct State {
    /// The law's input of the last cycle: a field this cycle does not set (the peer's, with no sample held) keeps it.
    control::ThreeChannelLaw::Input input;
    bool reaction_latched = false;  ///< The reaction holds the state latched at the loss of coupling.
    bool clutch_latched = false;    ///< The clutch's hold latched its target at the press.
    bool index_pending = false;     ///< Master: clutched since the last coupling; re-index at the next aligning.
    DofVector index_offset_m;       ///< Master: added to the position before the law and the wire (local frame).
    std::uint64_t reindexes = 0;
    DofVector last_reference_m;         ///< The coupling reference of the previous cycle (local frame).
    double max_reference_step_m = 0.0;  ///< Largest one-cycle jump of the reference while (re)engaging.
  };
  struct Input {
    const device::Reading* reading = nullptr;
    const proto::SampleMessage* peer = nullptr;  ///< The newest peer sample held (null: none).
    bool coupling = false;                       ///< EngagementMachine::coupling() after this cycle's Update.
    bool aligning = false;                       ///< ... and in aligning.
    EngagementMachine::Transition transition;
    bool clutched = false;                       ///< Any clutch source held (Clutch::Output::sources != 0).
    bool clutch_path = false;                    ///< Clutch::Output::clutch_path.
    const DofVector* last_velocity = nullptr;    ///< The law's velocity of the previous cycle (the reactions' latch).
    const DofVector* last_coupling_N = nullptr;  ///< The limiter's last coupling force (the reactions' latch).
    double t_s = 0.0;
    double period_s = 0.0;
  };
  struct Output {
    control::ThreeChannelLaw::Input input;  ///< What the law is to see.
    DofVector peer_local_m;                 ///< The peer's position in the local frame.
    bool reindexed = false;                 ///< A master re-indexed this cycle: shift the law's frame by shift_m.
    DofVector shift_m;
    double largest_offset_m = 0.0;  ///< The re-index's largest offset (the event's value).
    bool aligned = false;           ///< The Aligner's verdict (Aligner::aligned), for the shaper while aligning.
  };

  explicit LawInputStage(const Config& config);

  Output Step(const Input& in, Reactions& reactions) noexcept;

  const State& state() const noexcept { return state_; }

 private:
  void NotCoupled(const Input& in, Reactions& reactions) noexcept;
  void Coupled(const Input& in, Output& out) noexcept;
  void Reindex(const device::Reading& reading, Output& out) noexcept;
  void Align(const Input& in, const DofVector& peer_local_m) noexcept;

  Config config_;
  Aligner aligner_;
  State state_;
};

}  // namespace teleop::node
