#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <string>

#include "teleop/device/device_configuration.hpp"
#include "teleop/types.hpp"

namespace teleop::device {

/// How a backend renders force on its handle or tool. The node refuses, at start-up, a law or fixture the device
/// cannot render (teleop/config/render_check.hpp).
enum class Rendering : std::uint8_t {
  kActiveForce,           ///< Motors only: pushes and resists (haptic paddle, the loopback plant).
  kActiveAndDissipative,  ///< Motor + brake (Kwon & Song): active force plus a brake that can only resist motion.
  kDissipativeOnly,       ///< Brakes or dampers only: resists motion, never injects energy.
  kSteeredConstraints,    ///< Cobot (Colgate et al.): no force actuator; constrains the direction of motion.
};

const char* ToString(Rendering rendering) noexcept;

/// What a backend can do; the node's start-up checks, the law set-up and `--list-devices` read it.
struct Capabilities {
  int dof = 1;
  Rendering rendering = Rendering::kActiveForce;
  /// Per axis, the largest |force| the active actuator renders (N); empty or +inf: no limit of its own. Zero on a
  /// device without an active actuator (kDissipativeOnly, kSteeredConstraints).
  DofVector max_force_N;
  bool has_brake = false;       ///< A brake (or damper) that resists motion (kActiveAndDissipative, kDissipativeOnly).
  DofVector max_brake_force_N;  ///< Per axis, the brake's largest resisting force (N), when has_brake.
  bool measures_velocity = false;  ///< Reading::velocity_m_per_s is a sensor value (else the law estimates it).
  bool measures_force = false;     ///< Reading::force_N is a handle (master) or tool (slave) force sensor.
  /// A device made of joints (an arm, docs/arms.md): how many joints it reports in Reading::joint_position_rad and
  /// joint_torque_Nm (0..kMaxDof; telemetry's joint columns). 0: a Cartesian device, no joint readings.
  int joints = 0;

  /// True when the device can push its handle/tool (inject energy): kActiveForce or kActiveAndDissipative.
  bool can_push() const noexcept {
    return rendering == Rendering::kActiveForce || rendering == Rendering::kActiveAndDissipative;
  }
  /// The active limit on `axis` (N); +inf when the backend has none.
  double max_force_on(int axis) const noexcept {
    if (axis < 0 || axis >= max_force_N.size()) return std::numeric_limits<double>::infinity();
    return max_force_N[axis];
  }
};

/// Fault bits a backend reports. Any set bit puts the process into its safe state.
enum FaultBits : std::uint32_t {
  kFaultNone = 0,
  kFaultNonFiniteSensor = 1u << 0,  ///< NaN/inf read from a sensor.
  kFaultOutOfRange = 1u << 1,       ///< Position beyond the configured workspace.
  kFaultCommunication = 1u << 2,    ///< Driver lost its bus (CAN/Modbus).
  kFaultOvertemperature = 1u << 3,
  kFaultEmergencyStop = 1u << 4,
  kFaultDriver = 1u << 5,       ///< Any other driver-reported fault (also: a rejected command or update).
  kFaultImplausible = 1u << 6,  ///< Set by the node: an encoder jump beyond safety.max_speed_m_per_s (docs).
  /// A linkage at a singular configuration, where it cannot render force along some direction (an arm's
  /// manipulability below its bound, docs/arms.md).
  kFaultSingular = 1u << 7,
};

/// Warning bits a backend reports. Unlike a fault, a warning never changes what the node does: the node records it
/// (telemetry, events on each change, DDS, summary) so an operator sees a condition the backend's own checks flag.
enum WarningBits : std::uint32_t {
  kWarningNone = 0,
  /// The backend's own stability guard is past its margin (the cobot's eq 10 tracking guard, `stability: warn`).
  kWarningStabilityGuard = 1u << 0,
  kWarningSaturated = 1u << 1,  ///< An actuator held at its limit this cycle (the backend clamped the command).
};

/// Most constraints one Command carries: the forbidden-region fixture's plane capacity
/// (control::ForbiddenRegionFixture::kMaxPlanes; the node checks they agree).
inline constexpr int kMaxConstraints = 8;

/// One plane of the fixture that produced a Command, in the device's base frame: the points p with
/// normal·p > offset_m are forbidden (control::FixturePlane).
struct Constraint {
  DofVector normal;            ///< Unit normal pointing into the forbidden region (dimensionless, base frame).
  double offset_m = 0.0;       ///< Signed distance of the plane from the origin along `normal` (m).
  double penetration_m = 0.0;  ///< normal·x - offset_m at the position the law used (m); > 0: inside, the plane acts.
};

/// What the loop asks the device to render for the coming period. Fixed capacity: copying it never allocates.
struct Command {
  DofVector force_N;  ///< Force for the actuator (N, base frame), after the law's saturation; zero in the safe state.
  DofVector fixture_force_N;  ///< The fixture's share of force_N (N, base frame; the law's fixture_force_N).
  double fixture_stiffness_N_per_m = 0.0;  ///< K of the fixture that produced `constraints` (0: no fixture).
  /// Every plane of the enabled fixture (0 when the fixture is disabled), in the fixture's order; a plane is
  /// active when its penetration_m > 0. A force device can ignore them (force_N already holds the fixture force);
  /// a cobot steers along them, a brake device can use them to decide when to brake.
  int constraint_count = 0;
  std::array<Constraint, kMaxConstraints> constraints{};

  /// A command of force only (no constraints), for tests and simple callers. Set-up or cycle: no allocation.
  static Command Force(const DofVector& force_N) noexcept {
    Command c;
    c.force_N = force_N;
    c.fixture_force_N = DofVector::Zero(force_N.size());
    return c;
  }
};

/// One sample of a device, base frame of that device.
struct Reading {
  DofVector position_m;        ///< Measured position (m).
  DofVector velocity_m_per_s;  ///< Measured velocity (m/s), valid when Capabilities::measures_velocity.
  DofVector force_N;           ///< Handle (master) or tool (slave) force sensor (N), valid when measures_force.
  /// The force the actuators actually rendered over the last period (N, base frame): the command after the
  /// backend's own clamping (force limits, a brake that only resists, a rejected command replaced by zero). Zero
  /// before the first Write and in the safe state. Telemetry records it next to the command.
  DofVector rendered_force_N;
  std::uint32_t faults = kFaultNone;
  std::uint32_t warnings = kWarningNone;  ///< WarningBits; informational, the node records them and acts on none.
  /// The operator's clutch (pedal or button) is pressed: the pair decouples and re-indexes on release
  /// (docs/clutch.md). A backend without one leaves it false. The loopback plant's is scripted; the hybrid's
  /// fieldbus rig reads the Modbus input named `clutch` of its amplifier's register map (a discrete input,
  /// function 0x02). Not built yet: a CiA 402 drive's digital inputs object 0x60FD as a source.
  bool clutch_pressed = false;
  /// A device made of joints (Capabilities::joints > 0): each joint's position (rad; m for a prismatic joint) and
  /// the torque its actuator reports (N·m; N), Capabilities::joints entries. Empty (size 0) on other devices.
  DofVector joint_position_rad;
  DofVector joint_torque_Nm;
};

/// The one interface every backend implements: loopback plant, hybrid motor–brake device, cobot, real drivers.
///
/// Lifecycle (set-up, outside the loop; like ros2_control's on_configure / on_activate / on_deactivate):
///   constructor  validates the parsed config (no I/O);
///   Configure()  opens the bus, checks the drives are there, sizes buffers; capabilities() is final after it;
///   Activate()   brings the device to the state where it renders commands (CiA 402 Operation Enabled, homed);
///   Deactivate() puts it into the safe state and stops rendering; Activate() may follow again.
/// Configure and Activate throw teleop::Error with a message a user can act on; the defaults do nothing, so a
/// simulated backend implements only the cycle.
///
/// The cycle, once per period and in this order, on the real-time thread: Read(), the law, Write() (or SetSafe()
/// on a fault), Update(period_s). No allocation, no locks, no blocking I/O, no exceptions, no logging.
class Device {
 public:
  virtual ~Device() = default;
  Device() = default;
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  virtual const Capabilities& capabilities() const noexcept = 0;
  /// The backend's registry name ("loopback", "hybrid", "cobot", ...).
  virtual const std::string& name() const noexcept = 0;

  virtual void Configure() {}
  virtual void Activate() {}
  virtual void Deactivate() noexcept { SetSafe(); }

  /// Latest measurement. Never blocks.
  virtual void Read(Reading& out) noexcept = 0;
  /// The command for the coming period. A backend renders what it can (it clamps to its limits; a brake only
  /// resists) and reports the force it rendered in Reading::rendered_force_N of the next Read(). A command it
  /// cannot use at all (wrong size, NaN) is replaced by zero force and reported as kFaultDriver in the next Read().
  virtual void Write(const Command& command) noexcept = 0;
  /// Called after Write(): a simulated backend integrates its dynamics over `period_s` under the held command; a
  /// driver flushes its frames.
  virtual void Update(double period_s) noexcept = 0;
  /// Zero force (or engage brakes): the safe state. Must be callable at any time, also after a fault.
  virtual void SetSafe() noexcept = 0;

  /// Where a device whose stability model depends on its configuration (an arm) publishes it: its Read() writes
  /// the configuration it read there every cycle (wait-free, no allocation), the run-time limit's thread reads it
  /// (config::ConfigurationLimit; DeviceBackend::configuration_model). nullptr (the default): none.
  virtual ConfigurationMailbox* configuration_mailbox() noexcept { return nullptr; }

  /// The first fault since Activate in words, for the operator: what failed and where ("joint 3 'elbow': coil
  /// over-temperature (code 0xC)"). Empty when there is none or the backend names none (the fault bits say what
  /// they can). Any thread: the event log calls it when it logs a device fault. Not for the cycle (it allocates).
  virtual std::string FaultText() const { return {}; }
};

}  // namespace teleop::device
