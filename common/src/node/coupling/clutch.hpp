#pragma once

// The clutch stage of the coupling (docs/clutch.md): who holds the clutch, its press and release, and the blocker
// the engagement machine sees. Private to the node.

#include <cstdint>

#include "teleop/node/engagement.hpp"

namespace teleop::node {

/// Who holds the clutch (bits of Applied::clutch_sources and of the clutch events' value).
enum ClutchSource : std::uint8_t {
  kClutchDevice = 1u << 0,   ///< device::Reading::clutch_pressed (a pedal or button of the backend).
  kClutchPeer = 1u << 1,     ///< The peer's fresh sample carries kFlagClutched.
  kClutchCommand = 1u << 2,  ///< The command channel (TeleopNode::SetClutch).
};

/// The lowest-precedence blocker: a fault or a lost peer still chooses the reaction; the clutch's own command
/// applies only when nothing else is wrong. Allocation-free and noexcept in Step.
class Clutch {
 public:
  struct Config {
    bool master = false;
    bool can_push = false;  ///< The device renders active force: a clutched slave holds (else: its reaction).
  };
  struct State {
    std::uint8_t sources = 0;  ///< Of the previous cycle (press/release on a change).
    std::uint64_t presses = 0;
  };
  struct Input {
    bool device_pressed = false;     ///< device::Reading::clutch_pressed.
    bool command_pressed = false;    ///< Changes::command_clutch.
    bool peer_pressed = false;       ///< The peer's fresh sample carries kFlagClutched.
    Outage blocker = Outage::kNone;  ///< What else blocks coupling this cycle (Blocker()).
    bool index_pending = false;      ///< Master: clutched since the last coupling (LawInputStage's state).
  };
  struct Output {
    std::uint8_t sources = 0;        ///< ClutchSource bits pressed this cycle (0: not clutched).
    bool pressed = false;            ///< Pressed this cycle (no source held last cycle).
    bool released = false;           ///< Released this cycle.
    Outage blocker = Outage::kNone;  ///< The input's, or kClutch when only the clutch blocks.
    bool clutch_path = false;  ///< The clutch blocks and its own command applies (master, or a slave that pushes).
    bool flag = false;         ///< kFlagClutched of this cycle's sample.
  };

  explicit Clutch(const Config& config) : config_(config) {}

  Output Step(const Input& in) noexcept;

  const State& state() const noexcept { return state_; }

 private:
  Config config_;
  State state_;
};

}  // namespace teleop::node
