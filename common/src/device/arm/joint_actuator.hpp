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
#include <string_view>

namespace teleop::device::arm {

/// What kind of fault an actuator reports (the arm device maps it to the node's fault bits).
enum class JointFaultKind : std::uint8_t {
  kDriver,           ///< The drive's own fault (kFaultDriver).
  kNoReply,          ///< It stopped answering on its bus (kFaultCommunication).
  kOverTemperature,  ///< Its MOS or coil is too hot (kFaultOvertemperature).
};

/// One joint as its actuator reports it, read once per cycle.
struct JointSample {
  double position = 0.0;   ///< rad (m).
  double velocity = 0.0;   ///< rad/s (m/s).
  double torque_Nm = 0.0;  ///< The torque the actuator reports applying (N·m; N), or the command echoed.
  double temperature_C = std::numeric_limits<double>::quiet_NaN();  ///< NaN: the actuator has no sensor.
  bool fault = false;  ///< The actuator reports a fault (it no longer renders commands).
  JointFaultKind fault_kind = JointFaultKind::kDriver;  ///< When `fault`.
  std::uint32_t fault_code = 0;      ///< The actuator's own code when `fault` (e.g. an MIT motor's error nibble).
  bool temperature_warning = false;  ///< At or above the actuator's warning temperature.
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
  /// A position and velocity target for an actuator that runs its own PD (an MIT motor with `control: pd`); the
  /// others ignore it. Sent at the next JointBus::Exchange with the torque as the feed-forward.
  virtual void WriteTarget(double /*position*/, double /*velocity*/) noexcept {}
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
  /// The cycle's bus exchange (device::BusExchange, before the arm's Read): what the bus brought since the last
  /// cycle in, and what must leave at the start of the cycle out (a CiA 402 bus's SYNC). A bus that exchanges in
  /// Exchange alone (MIT motors, the simulated arm) does nothing here.
  virtual void StartCycle() noexcept {}
  /// After every joint's WriteTorque: sends the torques and receives the next samples (a driver), or integrates the
  /// dynamics over `period_s` under the written torques (a simulation).
  virtual void Exchange(double period_s) noexcept = 0;
  /// The name of an actuator's fault code (JointSample::fault_code), for messages: a static string.
  virtual std::string_view FaultName(std::uint32_t /*fault_code*/) const noexcept { return "actuator fault"; }
};

}  // namespace teleop::device::arm
