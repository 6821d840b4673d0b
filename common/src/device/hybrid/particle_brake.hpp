#pragma once

namespace teleop::device::hybrid {

/// One joint's magnetic particle brake (§2.2, Ogura OPB-40N): commanded torque 0…max_torque_Nm at its shaft, a
/// first-order lag, a drag torque present even unpowered, optional hysteresis, and the same pulley stage as the
/// motor. Paper values: 4 N·m, 50 ms, 0.08 N·m, 5:1; hysteresis is off by default (the paper defers it to Russo &
/// Tadros).
///
/// The brake delivers a *capacity*: the largest friction torque it can exert. The torque it actually exerts is
/// decided by the rig's dynamics (BrakeFrictionSolver): it opposes the joint's motion, or at rest the torque applied
/// to the joint, and never exceeds the capacity — so it can only remove energy.
struct BrakeConfig {
  double max_torque_Nm = 4.0;      ///< At the brake shaft.
  double time_constant_s = 0.050;  ///< First-order lag of the capacity; 0 = none.
  double drag_Nm = 0.08;           ///< Unpowered drag torque at the shaft.
  /// Width of a play (backlash) operator on the lagged torque, N·m at the shaft: on a reversal of the command the
  /// delivered torque stays until the command has moved by this much. 0 = no hysteresis.
  double hysteresis_Nm = 0.0;
  /// Remanence: after a release the brake keeps this fraction of the largest torque it has delivered (the particles'
  /// residual magnetisation; the paper gives no number: 2 % by default, 0.08 N·m after a full 4 N·m, the size of the
  /// drag). 0 = none.
  double residual_fraction = 0.02;
  /// Static torque / sliding torque: a stuck brake holds up to static_ratio × its capacity before it slips, a sliding
  /// one exerts its capacity (1.1 by default: particle brakes slip smoothly, static a little above dynamic; 1 = none).
  double static_ratio = 1.1;
  double pulley_ratio = 5.0;

  double MaxJointTorqueNm() const noexcept { return (max_torque_Nm + drag_Nm) * pulley_ratio; }
  void Validate() const;  ///< teleop::Error for negative or non-finite values, or a non-positive max or ratio.
};

/// Config + state + Step. Real-time safe; a non-finite command is treated as zero (brake released).
class ParticleBrake {
 public:
  explicit ParticleBrake(const BrakeConfig& config);

  /// Advances the lag by period_s under shaft command command_shaft_Nm (clamped to 0…max); returns the joint-side
  /// capacity (N·m, ≥ drag × ratio).
  double Step(double command_shaft_Nm, double period_s) noexcept;
  /// Joint-side capacity now: (drag + delivered) × ratio.
  double capacity_joint_Nm() const noexcept;
  double delivered_shaft_Nm() const noexcept { return delivered_shaft_Nm_; }
  void Reset() noexcept;
  const BrakeConfig& config() const noexcept { return config_; }

 private:
  BrakeConfig config_;
  double lagged_shaft_Nm_ = 0.0;
  double delivered_shaft_Nm_ = 0.0;
  double peak_shaft_Nm_ = 0.0;
};

}  // namespace teleop::device::hybrid
