#pragma once

#include "teleop/control/three_channel_law.hpp"
#include "teleop/node/engagement_config.hpp"
#include "teleop/types.hpp"

namespace teleop::node {

/// The command while a process is not coupled (safety.reaction, teleop/node/engagement_config.hpp), latched at the
/// moment coupling stopped. The law still runs every cycle (velocity estimate, fixture): hold and decelerate give it
/// a virtual still (or decelerating) peer at the latched position, the others run it without a peer and reshape its
/// output. Allocation-free and noexcept after construction.
class SafeReaction {
 public:
  /// `law` gives the position scale and the actuator limit (max_force_N, 0 = none).
  SafeReaction(const SafetyConfig& safety, const control::ThreeChannelLaw::Config& law);

  /// Latches the state at the loss of coupling: local position and velocity (local frame), and the coupling part of
  /// the force applied in the last cycle (command minus the fixture's share), for kFade.
  void Latch(const DofVector& position_m, const DofVector& velocity_m_per_s, const DofVector& coupling_force_N,
             double t_s) noexcept;
  /// Sets the law input's peer fields for this cycle (kHold, kDecelerate: a virtual peer; else no peer).
  void PrepareInput(control::ThreeChannelLaw::Input& input, double period_s) noexcept;
  /// The force to command from the law's output. Returns false when the device is to be put into its safe state
  /// instead (kBrake: Device::SetSafe engages the brake); `command_N` is then zero.
  bool Command(const control::ThreeChannelLaw::Output& out, double t_s, DofVector& command_N) noexcept;

  Reaction reaction() const noexcept { return safety_.reaction; }
  /// The position the reaction holds (kHold) or the decelerating reference (kDecelerate), local frame.
  const DofVector& target_m() const noexcept { return target_m_; }

 private:
  void Clamp(DofVector& force_N, double limit_N) const noexcept;

  SafetyConfig safety_;
  double position_scale_;
  double max_force_N_;
  DofVector target_m_;
  DofVector target_velocity_m_per_s_;
  DofVector latched_coupling_N_;
  double latched_s_ = 0.0;
};

}  // namespace teleop::node
