#pragma once

#include <cstdint>
#include <string>

#include "teleop/types.hpp"

namespace teleop::device {

/// What a backend can do; the law and the start-up checks read it.
struct Capabilities {
  int dof = 1;
  bool renders_active_force = true;   ///< Motors: can push the operator (haptic paddle, loopback plant).
  bool dissipative_only = false;      ///< Brakes/dampers only: can resist motion, never inject energy.
  bool steering_constraints = false;  ///< Cobot: constrains direction of motion by steering, not by force.
  bool measures_velocity = false;     ///< Reading::velocity is a sensor value (else the law estimates it).
  bool measures_force = false;        ///< Reading::force_N is a handle/tool force sensor.
};

/// Fault bits a backend reports. Any set bit puts the process into its safe state.
enum FaultBits : std::uint32_t {
  kFaultNone = 0,
  kFaultNonFiniteSensor = 1u << 0,  ///< NaN/inf read from a sensor.
  kFaultOutOfRange = 1u << 1,       ///< Position beyond the configured workspace.
  kFaultCommunication = 1u << 2,    ///< Driver lost its bus (CAN/Modbus).
  kFaultOvertemperature = 1u << 3,
  kFaultEmergencyStop = 1u << 4,
  kFaultDriver = 1u << 5,  ///< Any other driver-reported fault.
};

/// One sample of a device, base frame of that device.
struct Reading {
  DofVector position_m;        ///< Measured position (m).
  DofVector velocity_m_per_s;  ///< Measured velocity (m/s), valid when Capabilities::measures_velocity.
  DofVector force_N;           ///< Handle (master) or tool (slave) force sensor (N), valid when measures_force.
  std::uint32_t faults = kFaultNone;
};

/// The one interface every backend implements: loopback plant, hybrid motor–brake device, cobot, real drivers.
///
/// The loop calls, once per cycle and in this order: Read(), the law, Write(), Update(period_s). All three are
/// called from the real-time thread: no allocation, no locks, no blocking I/O, no exceptions. Set-up (opening a
/// bus, homing) happens in the backend's constructor and may throw teleop::Error.
class Device {
 public:
  virtual ~Device() = default;
  Device() = default;
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  virtual const Capabilities& capabilities() const noexcept = 0;
  /// The backend's registry name ("loopback", "hybrid", "cobot", ...).
  virtual const std::string& name() const noexcept = 0;

  /// Latest measurement. Never blocks.
  virtual void Read(Reading& out) noexcept = 0;
  /// Force command (N, base frame) for the coming period. A backend clamps to what it can render (a brake only
  /// dissipates) and reports what it did in the next Reading.
  virtual void Write(const DofVector& command_N) noexcept = 0;
  /// Called after Write(): a simulated backend integrates its dynamics over `period_s` under the held command; a
  /// driver flushes its frames.
  virtual void Update(double period_s) noexcept = 0;
  /// Zero force (or engage brakes): the safe state. Must be callable at any time, also after a fault.
  virtual void SetSafe() noexcept = 0;
};

}  // namespace teleop::device
