#pragma once

namespace teleop::device::hybrid {

/// One joint's motor as the simulated rig sees it (§2.2): a BLDC motor with its reducer giving at most
/// max_torque_Nm at the reducer output, a first-order lag of the delivered torque behind its command, and a pulley
/// stage of pulley_ratio:1 to the joint. Paper values: 4.44 N·m, 5:1.
///
/// The torque lag is the amplifier's current (torque) loop: 0.5 ms by default. The paper's "time constant ... of the
/// motor, 7 ms" (§2.2) is, for a Maxon 120 W BLDC, the catalogue's *mechanical* time constant τ_m = R·J_rotor/k_M²:
/// how fast the unloaded rotor reaches its speed under a voltage step. Under current control the torque follows the
/// current with the electrical time constant L/R (tenths of a millisecond for such a motor) and the loop's bandwidth
/// (about 1 kHz for a servo amplifier), not τ_m; the rotor inertia behind τ_m is in HybridRigConfig::
/// joint_inertia_kgm2. A 7 ms torque lag is available (time_constant_s = 0.007) to show what it would do: the
/// scenarios print which lag they use, and docs/hybrid.md has both.
struct MotorConfig {
  double max_torque_Nm = 4.44;      ///< At the reducer output (pulley 1 axis).
  double time_constant_s = 0.0005;  ///< Current-loop (torque) lag of the delivered torque; 0 = none.
  double pulley_ratio = 5.0;        ///< Joint torque = pulley_ratio × shaft torque.

  double MaxJointTorqueNm() const noexcept { return max_torque_Nm * pulley_ratio; }
  void Validate() const;  ///< teleop::Error on a non-positive limit or ratio, or a negative time constant.
};

/// Config + state + Step: the commanded joint torque is saturated to ±max and passed through the lag, exactly
/// discretised (zero-order-held command). Real-time safe; a non-finite command is treated as zero.
class MotorModel {
 public:
  explicit MotorModel(const MotorConfig& config);

  /// Advances the lag by period_s under joint-side command command_Nm; returns the delivered joint torque (N·m).
  double Step(double command_joint_Nm, double period_s) noexcept;
  double joint_torque_Nm() const noexcept { return torque_joint_Nm_; }
  void Reset() noexcept { torque_joint_Nm_ = 0.0; }
  const MotorConfig& config() const noexcept { return config_; }

 private:
  MotorConfig config_;
  double torque_joint_Nm_ = 0.0;
};

}  // namespace teleop::device::hybrid
