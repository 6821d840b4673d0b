#pragma once

// The arm's joints on MIT-mode CAN motors (docs/arms.md, "MIT motors"; docs/mit-motors.md): a JointBus over one
// MitMotorBus, `actuators: mit`.
//
//   Joint ↔ motor:  q = offset + sign·θ/gear,  q̇ = sign·θ̇/gear,  τ_motor = sign·τ_joint/gear  (θ the motor's output
//                   shaft as it reports it; gear the reduction between that shaft and the joint, 1 for a DM-J motor
//                   mounted directly at its joint).
//   Control:        torque (default): Kp = Kd = 0, feed-forward = the arm's torque; or pd: the motor's own PD with
//                   the joint's Kp, Kd (converted to the motor side, /gear²) to the target written
//                   (JointActuator::WriteTarget; without one, the joint's last reading at zero velocity), plus the
//                   arm's torque as the feed-forward.
//   Configure:      checks every motor's ranges (registers 21..23) and control mode (MIT), writes its CAN timeout
//                   (register 9) so a dead host leaves it disabled.
//   Activate:       enables every motor (an error naming the joints that do not answer or report a fault), then
//                   disables them again: a motor's own CAN timeout counts only while it is enabled, and the loop's
//                   first cycle may come long after Activate. The first Exchange sends every motor its enable right
//                   before its first command, so the timeout counts from the first command.
//   Exchange:       one bus exchange per cycle: the replies of the last exchange in, the commands out, then (a real
//                   bus) up to `reply_wait_us` for this exchange's replies, or (the simulated arm) the plant advanced
//                   over the period. A motor without a reply for `missing_limit` exchanges in a row, a motor's fault
//                   code, a temperature at or above `temperature_fault_C`, a motor that reports disabled while
//                   active, or one that answers but has not shown enabled within `missing_limit` exchanges after
//                   the loop's enable (kMitFaultNeverEnabled) is a fault of that joint; on any fault every motor is
//                   disabled and stays so until the next Activate.
//   Deactivate:     disables every motor.
// No allocation, lock or exception in Exchange, Read or WriteTorque.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "joint_actuator.hpp"
#include "teleop/fieldbus/can_port_config.hpp"
#include "teleop/fieldbus/canopen_timebase.hpp"
#include "teleop/fieldbus/mit_motor_bus.hpp"
#include "teleop/fieldbus/mit_motor_models.hpp"

namespace teleop::device::arm {

/// One joint's motor.
struct MitJointConfig {
  std::string model;              ///< The models table's name (DM-J8009, ...).
  fieldbus::MitMotorModel motor;  ///< Its ranges and peak torque (from the table).
  std::uint32_t esc_id = 1;
  std::uint32_t master_id = 0x11;
  double sign = 1.0;            ///< +1 or -1: the motor turns with or against the URDF joint's axis.
  double offset_rad = 0.0;      ///< The joint's position when the motor reads 0 (rad).
  double gear_ratio = 1.0;      ///< Motor output turns per joint turn, > 0.
  double kp_Nm_per_rad = 0.0;   ///< control: pd, joint side.
  double kd_Nms_per_rad = 0.0;  ///< control: pd, joint side.
};

enum class MitControl : std::uint8_t { kTorque, kPd };

struct MitJointBusConfig {
  std::vector<MitJointConfig> joints;  ///< In the chain's order.
  MitControl control = MitControl::kTorque;
  int missing_limit = 10;               ///< Exchanges in a row without a reply that make a fault.
  double answer_timeout_ms = 20.0;      ///< Set-up: how long a register read or enable waits.
  double motor_timeout_ms = 50.0;       ///< Written to each motor's register 9 (0: off; not recommended).
  double reply_wait_us = 400.0;         ///< A real bus: how long Exchange waits for this cycle's replies.
  double temperature_warning_C = 70.0;  ///< MOS or rotor at or above: kArmWarningTemperature.
  double temperature_fault_C = 100.0;   ///< MOS or rotor at or above: a fault (before the motor's own, ~120 °C).
  // The bus.
  bool simulated = false;  ///< The simulated MIT arm in process (simulated_mit_arm.hpp); else `can`.
  fieldbus::CanPortConfig can;
  bool fd = true;                          ///< CAN FD frames (the bit-rate switch on).
  double nominal_bitrate_bit_per_s = 1e6;  ///< The bus-load budget's arbitration rate.
  double data_bitrate_bit_per_s = 5e6;     ///< The bus-load budget's FD data rate.
  double max_bus_load = 0.8;               ///< The budget: refused above this fraction of the bus.
  double rate_hz = 1000.0;                 ///< The cycle rate the budget is computed at (the process's rate_hz).
};

/// The bus-load budget of `config` at its rate_hz (proto::can::mit::ComputeMitBusLoad): throws teleop::Error when
/// the motors do not fit, saying what would (CAN FD, more buses, a lower rate). `where` names the config key.
void CheckMitBusLoad(const MitJointBusConfig& config, const std::string& where);

/// The in-process plant a simulated bus advances (the simulated MIT arm): its clock is the bus's.
class MitPlant {
 public:
  virtual ~MitPlant() = default;
  /// Advances the bus, the motors and the arm over `period_s` (the cycle).
  virtual void Advance(double period_s) noexcept = 0;
  /// The set-up clock and wait (the bus and the motors advance; the arm holds still).
  virtual fieldbus::Timebase timebase() = 0;
};

/// Fault codes of an MIT joint (JointSample::fault_code): the motor's status nibble 0x0..0xF, and the host's own.
inline constexpr std::uint32_t kMitFaultNoReply = 0x100;
inline constexpr std::uint32_t kMitFaultHostTemperature = 0x101;
inline constexpr std::uint32_t kMitFaultDisabled = 0x102;
/// It answers, but no feedback showed it enabled within missing_limit exchanges after the loop's enable.
inline constexpr std::uint32_t kMitFaultNeverEnabled = 0x103;

class MitJointBus final : public JointBus {
 public:
  /// `plant`: the simulated arm behind the bus (it owns the bus `port` is on), or null (a real bus). `port` is the
  /// host's port and should receive ReceiveOptions(config). Throws teleop::Error on a bad config.
  MitJointBus(MitJointBusConfig config, std::unique_ptr<MitPlant> plant, std::unique_ptr<transport::CanPort> port,
              std::vector<std::string> joint_names);
  ~MitJointBus() override;

  int joint_count() const noexcept override { return static_cast<int>(joints_.size()); }
  JointActuator& joint(int i) noexcept override;
  void Configure() override;
  void Activate() override;
  void Deactivate() noexcept override;
  void Exchange(double period_s) noexcept override;
  std::string_view FaultName(std::uint32_t fault_code) const noexcept override;

  // Inspection (tests, telemetry).
  const fieldbus::MitMotorBus& bus() const noexcept { return *bus_; }
  bool faulted() const noexcept { return faulted_; }
  bool active() const noexcept { return active_; }
  MitPlant* plant() noexcept { return plant_.get(); }
  /// The motor-side command sent to joint `i` at the last exchange.
  const proto::can::mit::Command& command(int i) const noexcept;

  /// The receive options of `config`'s motors (for the port).
  static transport::CanReceiveOptions ReceiveOptions(const MitJointBusConfig& config);
  /// The motors of `config` as the host bus sees them.
  static std::vector<fieldbus::MitMotorConfig> Motors(const MitJointBusConfig& config,
                                                      const std::vector<std::string>& joint_names);

 private:
  class Joint;
  void UpdateSamples() noexcept;
  void Fault() noexcept;

  MitJointBusConfig config_;
  std::unique_ptr<MitPlant> plant_;  ///< Before port_: the port is on the plant's bus and goes first.
  std::unique_ptr<transport::CanPort> port_;
  std::vector<std::string> names_;
  std::unique_ptr<fieldbus::MitMotorBus> bus_;
  std::vector<std::unique_ptr<Joint>> joints_;
  bool active_ = false;
  bool faulted_ = false;
  bool enable_pending_ = false;     ///< Activate verified the enable and disabled again; the first Exchange enables.
  int exchanges_since_enable_ = 0;  ///< Exchanges since that enable (counted up to missing_limit).
};

}  // namespace teleop::device::arm
