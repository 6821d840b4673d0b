#pragma once

// A simulated MIT-mode joint motor (a Damiao DM-J class motor) on a CAN port (docs/mit-motors.md, "Simulated
// motor"): the same bytes a real motor speaks (proto/can/mit_motor.hpp), so the host code under test is the host
// code in use. The output shaft is a rigid body J·dω/dt = τ − b·ω − τ_c·sign(ω) + τ_load (sticks while |τ| ≤ τ_c at
// rest); in MIT mode the motor runs its own PD, τ = Kp·(p − θ) + Kd·(v − ω) + τ_ff, at the integration step (the
// drive's loop runs far faster than the bus), clamped to the motor's peak torque. It answers every frame addressed to
// it with a feedback frame, serves the parameter registers a bring-up uses, disables itself when no frame arrives
// within its CAN timeout (register 9) and reports "communication lost" (0xD), and takes injected faults.

#include <cstdint>

#include "teleop/proto/can/mit_motor.hpp"
#include "teleop/transport/can_filter.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::fieldbus {

struct SimulatedMitMotorConfig {
  std::uint32_t esc_id = 0x01;            ///< Register 8: the id it listens on (1..0x7FE).
  std::uint32_t master_id = 0x11;         ///< Register 7: the id it answers on.
  proto::can::mit::MotorRanges ranges{};  ///< Registers 21..23 at power-on (DM-J4310 defaults).
  double inertia_kg_m2 = 1.8e-3;  ///< At the output: rotor 1.8e-5 kg·m² through a 10:1 gearbox, plus the load.
  double viscous_Nms_per_rad = 0.02;
  double coulomb_Nm = 0.05;
  double peak_torque_Nm = 7.0;       ///< What the motor can give (DM-J4310: 7 N·m peak), below the T_MAX scale.
  std::uint32_t timeout_counts = 0;  ///< Register 9 at power-on, 50 µs per count; 0: no timeout.
  std::uint32_t firmware = 0x5013;   ///< Register 14.
  double temperature_C = 30.0;       ///< MOS and rotor temperature reported while no fault is injected.
  double integration_step_s = 1e-4;
  /// The shaft is driven from outside (a simulated arm's joint, docs/arms.md "MIT motors"): Step integrates nothing;
  /// the owner sets the shaft's state (SetShaft) and takes the motor's torque at it (OutputTorque).
  bool external_shaft = false;
};

class SimulatedMitMotor {
 public:
  /// `port` must outlive it and should receive ReceiveOptions(config).
  SimulatedMitMotor(const SimulatedMitMotorConfig& config, transport::CanPort& port);

  /// Its command id and the parameter id 0x7FF (classic and FD).
  static transport::CanReceiveOptions ReceiveOptions(const SimulatedMitMotorConfig& config);

  /// Advances the shaft to `now_ns` (a monotonic clock in ns), then serves every frame pending on the port. The
  /// first call only sets the clock. No allocation.
  void Step(std::int64_t now_ns) noexcept;

  /// Fault injection (tests, teleop-motor simulate): the code is latched, the motor disables and reports it in every
  /// feedback until a clear-error frame arrives after the cause is gone (ClearInjectedFault).
  void InjectFault(proto::can::mit::MotorStatus status) noexcept;
  void ClearInjectedFault() noexcept { injected_ = 0; }
  /// Stops answering (a motor whose CAN wire is cut): frames are still read, nothing is sent.
  void SetSilent(bool silent) noexcept { silent_ = silent; }
  /// Answers the enable frame (with its feedback) but stays disabled (code 0): a motor whose driver stage or
  /// firmware refuses the enable. Commands are answered and ignored, as while disabled.
  void SetIgnoreEnable(bool ignore) noexcept { ignore_enable_ = ignore; }
  /// An external torque on the shaft (the arm's link, the hand).
  void SetLoadTorque(double torque_Nm) noexcept { load_torque_Nm_ = torque_Nm; }
  /// The MOS and rotor temperature it reports while no over-temperature fault is injected (°C).
  void SetTemperature(double temperature_C) noexcept { config_.temperature_C = temperature_C; }

  /// External shaft only: the shaft's position (rad, before the zero offset) and velocity (rad/s) now.
  void SetShaft(double position_rad, double velocity_rad_per_s) noexcept {
    theta_rad_ = position_rad + zero_offset_rad_;
    omega_rad_per_s_ = velocity_rad_per_s;
  }
  /// The torque the motor applies at the shaft's state under its latest command: its PD plus the feed-forward,
  /// clamped to the peak torque; 0 while disabled or faulted (N·m). Kept for the feedback's torque field.
  double OutputTorque() noexcept;

  [[nodiscard]] double position_rad() const noexcept { return theta_rad_ - zero_offset_rad_; }
  [[nodiscard]] double velocity_rad_per_s() const noexcept { return omega_rad_per_s_; }
  [[nodiscard]] double torque_Nm() const noexcept { return torque_Nm_; }
  [[nodiscard]] std::uint8_t status() const noexcept { return status_; }
  [[nodiscard]] bool enabled() const noexcept {
    return status_ == static_cast<std::uint8_t>(proto::can::mit::MotorStatus::kEnabled);
  }
  [[nodiscard]] const proto::can::mit::MotorRanges& ranges() const noexcept { return ranges_; }
  [[nodiscard]] std::uint32_t timeout_counts() const noexcept { return timeout_counts_; }
  [[nodiscard]] std::uint64_t commands_received() const noexcept { return commands_received_; }
  [[nodiscard]] std::uint64_t frames_sent() const noexcept { return frames_sent_; }

 private:
  void Integrate(double dt_s) noexcept;
  void Serve(const proto::can::CanFrame& frame, std::int64_t now_ns) noexcept;
  void ServeSpecial(proto::can::mit::Special what) noexcept;
  void ServeParameter(const proto::can::mit::Parameter& request) noexcept;
  bool WriteRegister(std::uint8_t reg, std::uint32_t value) noexcept;
  [[nodiscard]] std::uint32_t ReadRegister(std::uint8_t reg) const noexcept;
  void SendFeedback() noexcept;
  void Send(const proto::can::CanFrame& frame) noexcept;

  SimulatedMitMotorConfig config_;
  transport::CanPort& port_;
  proto::can::mit::MotorRanges ranges_;
  std::uint32_t esc_id_;
  std::uint32_t master_id_;
  std::uint32_t timeout_counts_;
  std::uint32_t control_mode_ = proto::can::mit::kControlModeMit;
  std::int64_t last_ns_ = -1;
  std::int64_t last_frame_ns_ = 0;
  double theta_rad_ = 0;
  double omega_rad_per_s_ = 0;
  double torque_Nm_ = 0;
  double zero_offset_rad_ = 0;
  double load_torque_Nm_ = 0;
  double remainder_s_ = 0;
  proto::can::mit::Command command_{};
  std::uint8_t status_ = 0;
  std::uint8_t injected_ = 0;
  bool silent_ = false;
  bool ignore_enable_ = false;
  bool fd_seen_ = false;
  std::uint64_t commands_received_ = 0;
  std::uint64_t frames_sent_ = 0;
};

}  // namespace teleop::fieldbus
