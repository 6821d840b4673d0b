#pragma once

// The joint-actuator seam (docs/arms.md, "The joint-actuator seam"): what an arm needs of one joint's motor and
// drive, and of the bus that carries all of them. The arm backend (arm_device.hpp) sees nothing else, so a simulated
// arm (simulated_arm.hpp), MIT-mode CAN motors or CiA 402 drives in cyclic synchronous torque mode plug in behind it
// and the backend under test is the one that drives real joints.
//
// Units: a revolute joint in rad, rad/s and N·m; a prismatic one in m, m/s and N (the same fields). Positions are
// the URDF joint's coordinate (zero where the URDF's zero is; a driver applies its own offset and sign).

#include <cstdint>
#include <limits>

namespace teleop::device::arm {

/// One joint as its actuator reports it, read once per cycle.
struct JointSample {
  double position = 0.0;   ///< rad (m).
  double velocity = 0.0;   ///< rad/s (m/s).
  double torque_Nm = 0.0;  ///< The torque the actuator reports applying (N·m; N), or the command echoed.
  double temperature_C = std::numeric_limits<double>::quiet_NaN();  ///< NaN: the actuator has no sensor.
  bool fault = false;            ///< The actuator reports a fault (it no longer renders commands).
  std::uint32_t fault_code = 0;  ///< The actuator's own code when `fault` (e.g. an MIT motor's error nibble).
};

/// One joint's motor and drive. Called on the real-time thread: no allocation, no blocking, no exceptions.
class JointActuator {
 public:
  virtual ~JointActuator() = default;
  JointActuator() = default;
  JointActuator(const JointActuator&) = delete;
  JointActuator& operator=(const JointActuator&) = delete;

  /// The newest sample (from the last JointBus::Exchange).
  virtual void Read(JointSample& out) noexcept = 0;
  /// The torque for the coming period (N·m; N), already clamped by the arm to the joint's limit. Sent at the next
  /// JointBus::Exchange.
  virtual void WriteTorque(double torque_Nm) noexcept = 0;
};

/// The arm's joints and the bus that carries them: one exchange per cycle, in one named place (Exchange).
/// Lifecycle as the Device's: Configure (open the bus, find every joint), Activate (enable torque), Deactivate.
class JointBus {
 public:
  virtual ~JointBus() = default;
  JointBus() = default;
  JointBus(const JointBus&) = delete;
  JointBus& operator=(const JointBus&) = delete;

  virtual int joint_count() const noexcept = 0;
  /// Joint `i` in the chain's order (base to tool), 0 <= i < joint_count().
  virtual JointActuator& joint(int i) noexcept = 0;

  virtual void Configure() {}
  virtual void Activate() {}
  virtual void Deactivate() noexcept {}
  /// After every joint's WriteTorque: sends the torques and receives the next samples (a driver), or integrates the
  /// dynamics over `period_s` under the written torques (a simulation).
  virtual void Exchange(double period_s) noexcept = 0;
};

}  // namespace teleop::device::arm
