#pragma once

// The simulated MIT arm as a client of a shared CAN bus (docs/arms.md, "MIT motors"; docs/mit-motors.md, "The arm on
// the teleop-canbus daemon"): the simulated arm's rigid-body dynamics (simulated_arm.hpp) and one
// fieldbus::SimulatedMitMotor per joint (external shaft), all on one port of the section's `mit.can` bus (the
// teleop-canbus daemon, or a SocketCAN interface such as vcan0; one port, not one per motor: the daemon sends every
// frame to every port, and seven motor ports would multiply its work by seven), each motor reading the frames for its
// id (and the parameter id 0x7FF) from its own queue and writing to the shared port, run in real time by `teleop-arm
// simulate-motors`. The host process (teleop-master/teleop-slave with `mit.bus: can` on the same bus) and the motors
// are then separate processes, and every command and reply crosses the bus between them, as with real motors.
//
// Step(now_ns), called when the host's frames arrive (WaitForFrames) and at least every millisecond: the arm is
// integrated from the last call to `now_ns` in steps of at most max_step_s, each with the motors' torques at the
// shafts' state (their PD plus the feed-forward, clamped to the model's peak torque; τ_joint = sign·gear·τ_motor), the
// shafts following the arm; then every motor serves the frames that reached it (commands, enables, register reads, its
// CAN timeout) and answers. Until the host first enables a motor the arm holds still at `simulation.initial_q_rad` (on
// its stand: the host's set-up may take a while); from then on nothing holds it but its motors (they have no brakes).
// The same section (URDF, joints, ids, models, `simulation`) as the host's, so one config file serves both processes.

#include <cstdint>
#include <memory>
#include <vector>

#include "arm_section.hpp"
#include "simulated_arm.hpp"
#include "teleop/fieldbus/simulated_mit_motor.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::device::arm {

class SimulatedMitArmClient {
 public:
  /// The arm and motors of `section` (actuators: mit, mit.bus: can), their port opened on section.mit.can.
  /// Throws teleop::Error on a bad section or a bus that does not open (naming it).
  explicit SimulatedMitArmClient(const ArmSection& section, double max_step_s = 2.5e-4);
  ~SimulatedMitArmClient();

  /// Integrates the arm up to `now_ns` (a monotonic clock, ns), then serves every motor's frames. The first call only
  /// sets the clock. No allocation.
  void Step(std::int64_t now_ns) noexcept;

  /// Waits until a frame is pending on the bus port or its clock (now_ns()) reaches `deadline_ns`. The run loop.
  bool WaitForFrames(std::int64_t deadline_ns) noexcept { return port_->WaitReadable(deadline_ns); }
  std::int64_t now_ns() const noexcept { return port_->now_ns(); }

  int motor_count() const noexcept { return static_cast<int>(motors_.size()); }
  SimulatedArm& arm() noexcept { return *arm_; }
  fieldbus::SimulatedMitMotor& motor(int i) noexcept { return *motors_[static_cast<std::size_t>(i)]; }

 private:
  void FollowArm() noexcept;

  MitJointBusConfig config_;
  std::unique_ptr<SimulatedArm> arm_;
  double max_step_s_;
  std::int64_t last_ns_ = -1;
  bool released_ = false;  ///< A motor has been enabled: the arm moves from then on (held still before).
  class MotorPort;
  std::unique_ptr<transport::CanPort> port_;  ///< The one port on the bus.
  std::vector<std::unique_ptr<MotorPort>> motor_ports_;
  std::vector<std::unique_ptr<fieldbus::SimulatedMitMotor>> motors_;
};

}  // namespace teleop::device::arm
