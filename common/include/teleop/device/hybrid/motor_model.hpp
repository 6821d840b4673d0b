#pragma once

namespace teleop::device::hybrid {

/// One joint's motor as the simulated rig sees it (§2.2): a BLDC motor with its reducer giving at most
/// max_torque_Nm at the reducer output, a first-order current/torque lag, and a pulley stage of pulley_ratio:1 to
/// the joint. Paper values: 4.44 N·m, 7 ms, 5:1.
struct MotorConfig {
  double max_torque_Nm = 4.44;     ///< At the reducer output (pulley 1 axis).
  double time_constant_s = 0.007;  ///< First-order lag of the delivered torque; 0 = none.
  double pulley_ratio = 5.0;       ///< Joint torque = pulley_ratio × shaft torque.

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
