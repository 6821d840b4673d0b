#pragma once

// The shaper stage of the coupling: from the law's output to the command, by the path the cycle took (bounded
// force rate while aligning or clutched, the reaction when not coupled, the safe state). Private to the node.

#include <cstdint>

#include "law_input.hpp"
#include "teleop/control/three_channel_law.hpp"
#include "teleop/node/engagement.hpp"

namespace teleop::node {

/// Which path chose the command.
enum class CouplingPath : std::uint8_t { kDeviceFault, kNonFinite, kAligning, kEngaged, kReaction, kClutched };

/// The force-rate limiter around the law's output. Step shapes the command; Track, after the passivity stage, tells
/// the limiter the force actually applied. Allocation-free and noexcept.
class Shaper {
 public:
  struct Config {
    int dof = 1;
    bool master = false;
    double max_force_N = 0.0;             ///< law.max_force_N (0: no limit).
    double max_force_rate_N_per_s = 0.0;  ///< engagement.max_force_rate_N_per_s
  };
  struct State {
    bool aligned_verdict = false;  ///< Aligner reached the peer and the limiter did not clip (for the next Update).
    double max_aligning_force_rate = 0.0;  ///< Largest |Δ coupling force| / period aligning and at engagement.
    double max_clutch_force_rate = 0.0;    ///< Largest |Δ coupling force| / period while clutched (N/s).
  };
  struct Input {
    CouplingPath path = CouplingPath::kReaction;
    const control::ThreeChannelLaw::Output* law = nullptr;
    bool aligned = false;           ///< The Aligner's verdict this cycle (LawInputStage::Output::aligned).
    bool aligning_started = false;  ///< Resets the verdict.
    double t_s = 0.0;
    double period_s = 0.0;
  };
  struct Output {
    control::ThreeChannelLaw::Output command;  ///< command_N (0 in the safe state) and its fixture share.
    bool safe = false;                         ///< Device::SetSafe instead of Write.
  };

  explicit Shaper(const Config& config);

  Output Step(const Input& in, Reactions& reactions) noexcept;
  /// After the passivity stage: the limiter follows the force applied on the paths it does not limit.
  void Track(CouplingPath path, const control::ThreeChannelLaw::Output& law, const Output& applied, bool engaged_now,
             double period_s) noexcept;
  /// The coupling force the limiter let through last (the reactions' latch).
  const DofVector& last_coupling_N() const noexcept { return limiter_.last_N(); }

  const State& state() const noexcept { return state_; }

 private:
  void Limit(const DofVector& coupling_N, const control::ThreeChannelLaw::Output& law, double period_s,
             double& max_rate, Output& out) noexcept;
  void Clutched(const Input& in, Reactions& reactions, Output& out) noexcept;

  Config config_;
  ForceRateLimiter limiter_;  ///< The coupling part of the command while aligning or clutched; tracks it otherwise.
  State state_;
};

}  // namespace teleop::node
