#pragma once

// The arm's joints on CiA 402 drives in cyclic synchronous torque mode (docs/arms.md, "CiA 402 joints";
// docs/cia402.md): a JointBus over one fieldbus::Cia402Drive per joint, on one or more CAN buses, `actuators: cia402`.
//
//   Joint ↔ drive:  q = offset + sign·θ/gear,  q̇ = sign·θ̇/gear,  τ_drive = sign·τ_joint/gear  (θ the drive's
//                   position actual 0x6064 in its units × position_rad_per_count; the torque sent as 0x6071 in per
//                   mille of the drive's rated torque 0x6076, CiA 402, clamped to max_torque_Nm, 0x6072).
//   Configure:      every drive's set-up (Cia402Drive::Configure: NMT reset, PDO mapping written and read back, mode
//                   10, 0x6072, the rated torque checked, heartbeats), then its position by SDO, so the joints read
//                   a position before activation. An error names the joint, its node and bus.
//   Host heartbeat: one producer per bus (node host_node_id every host_heartbeat_period_ms), sent from every set-up
//                   wait and from StartCycle. At Activate each drive's consumer of it is switched on (0x1016:01 =
//                   host node << 16 | drive_consumer_timeout_ms, CiA 301), so a host that dies (or whose loop stops)
//                   leaves every drive in its fault reaction (EMCY 0x8130) within that time; Deactivate switches
//                   it off again, so a cleanly stopped host leaves no drive to fault.
//   Activate:       every drive to Operation Enabled through the state machine (a fault reset when it is in Fault),
//                   then SYNCs until every drive has sent its TPDOs in Operation Enabled, then a heartbeat on every
//                   bus (the loop's first cycle must follow within drive_consumer_timeout_ms). An error names the
//                   joint.
//   The cycle:      StartCycle() is the bus exchange (device::BusExchange, before Read): every drive's TPDOs of the
//                   previous SYNC in, then one SYNC per bus; Exchange(period) (after Write) queues every drive's
//                   RPDO (controlword + target torque), applied at the next SYNC, and (the simulated arm) advances
//                   the plant over the period. So every drive on a bus applies its torque on the same SYNC, a period
//                   after it was computed (docs/cia402.md, "SYNC on a bus with several drives").
//   Faults:         a drive in Fault (or an EMCY: the error code, 0x603F's, by name), one that leaves Operation
//                   Enabled, no TPDO for stale_after_ms, a lost heartbeat, bus-off or a refused frame is a fault of
//                   that joint; on any fault every drive gets Quick Stop (controlword bit 2 = 0, torque 0) from the
//                   next RPDO on and stays so until the next Activate.
//   Deactivate:     every drive to torque 0, Disable Operation, Shutdown, pre-operational (Cia402Drive::Deactivate),
//                   its heartbeat consumer off.
// No allocation, lock or exception in StartCycle, Exchange, Read or WriteTorque.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "joint_actuator.hpp"
#include "teleop/fieldbus/can_port_config.hpp"
#include "teleop/fieldbus/canopen_heartbeat_producer.hpp"
#include "teleop/fieldbus/canopen_sync_producer.hpp"
#include "teleop/fieldbus/canopen_timebase.hpp"
#include "teleop/fieldbus/cia402_drive.hpp"

namespace teleop::device::arm {

/// One joint's drive.
struct Cia402JointConfig {
  int bus = 0;                                        ///< Index into the buses (0-based).
  std::uint8_t node_id = 1;                           ///< 1..127, unique on its bus.
  double rated_torque_Nm = 1.0;                       ///< 0x6076 (the drive's side), the unit of 0x6071.
  double max_torque_Nm = 1.0;                         ///< 0x6072 (the drive's side); every target clamped to it.
  double position_rad_per_count = 1.0 / 4096.0;       ///< 0x6064's unit (the drive's side).
  double velocity_rad_per_s_per_unit = 1.0 / 4096.0;  ///< 0x606C's unit.
  double sign = 1.0;        ///< +1 or -1: the drive turns with or against the URDF joint's axis.
  double offset_rad = 0.0;  ///< The joint's position when the drive reads 0 (rad).
  double gear_ratio = 1.0;  ///< Drive turns per joint turn, > 0.
};

struct Cia402JointBusConfig {
  std::vector<Cia402JointConfig> joints;  ///< In the chain's order.
  bool simulated = false;                 ///< The simulated arm in process (simulated_cia402_arm.hpp); else `buses`.
  std::vector<fieldbus::CanPortConfig> buses;  ///< bus: can, one per bus index.
  double nominal_bitrate_bit_per_s = 1e6;      ///< Classic CAN: the bus-load budget's (and the emulated bus's) rate.
  double max_bus_load = 0.8;                   ///< The budget: refused above this fraction of a bus.
  double rate_hz = 1000.0;                     ///< The cycle rate (the process's rate_hz): SYNC period, budget.
  double stale_after_ms = 10.0;                ///< No TPDO for this long: a fault of the joint.
  double drive_heartbeat_period_ms = 50.0;     ///< 0x1017 of every drive.
  double heartbeat_timeout_ms = 150.0;         ///< The host's consumer of each drive's heartbeat.
  double host_heartbeat_period_ms = 100.0;     ///< The host's heartbeat on every bus (one producer per bus).
  std::uint8_t host_node_id = 127;             ///< The host's node-ID in its heartbeat (no drive may use it).
  /// Each drive's consumer of the host's heartbeat (0x1016:01, written at Activate, off at Deactivate), so a dead
  /// host stops the motors: the drive's fault reaction (EMCY 0x8130) this long after the host's last heartbeat. 0:
  /// off; else more than host_heartbeat_period_ms, at most 65535.
  double drive_consumer_timeout_ms = 300.0;
  double sdo_timeout_ms = 50.0;        ///< Set-up: how long one SDO waits.
  double activate_timeout_ms = 500.0;  ///< Activate: each state machine step, and the first TPDOs.
  /// Bus count: the largest joint's bus + 1.
  int bus_count() const noexcept;
};

/// The bus-load budget of `config` at its rate_hz, for each bus: one SYNC plus every drive's RPDOs and TPDOs per
/// cycle (worst-case stuffing, classic frames), the heartbeats beside them. Throws teleop::Error when a bus does not
/// fit, saying what would (drives per bus, buses for the joints, the highest rate). `where` names the config key.
void CheckCia402BusLoad(const Cia402JointBusConfig& config, const std::string& where);

/// The client configuration of joint `i`'s drive (produce_sync off: the bus's SYNC is the JointBus's; no host
/// heartbeat and no consumer of it: the bus's producer sends it, and the JointBus switches the consumer on at
/// Activate).
fieldbus::Cia402DriveConfig Cia402DriveConfigOf(const Cia402JointBusConfig& config, std::size_t i);

/// The in-process plant a simulated bus advances (the simulated CiA 402 arm): its clock is the buses'.
class Cia402Plant {
 public:
  virtual ~Cia402Plant() = default;
  /// Advances the buses, the drives and the arm over `period_s` (the cycle).
  virtual void Advance(double period_s) noexcept = 0;
  /// The set-up clock and wait (the buses and the drives advance; the arm holds still).
  virtual fieldbus::Timebase timebase() = 0;
  /// A host port on bus `bus` (one per drive client, as one socket per client on a real bus).
  virtual std::unique_ptr<transport::CanPort> MakeHostPort(int bus, const transport::CanReceiveOptions& options) = 0;
};

/// Fault codes of a CiA 402 joint (JointSample::fault_code): the drive's error code (EMCY, 0x603F) 0x0001..0xFFFF,
/// or kCia402FaultHost + the cycle's status (fieldbus::Cia402Status) when the host found it, kCia402FaultSync when
/// the joint's bus refused its SYNC, kCia402FaultHeartbeat when it refused the host's heartbeat.
inline constexpr std::uint32_t kCia402FaultHost = 0x10000;
inline constexpr std::uint32_t kCia402FaultHeartbeat = 0x100FE;
inline constexpr std::uint32_t kCia402FaultSync = 0x100FF;

class Cia402JointBus final : public JointBus {
 public:
  /// `plant`: the simulated arm behind the buses, or null (real buses: one port per drive opened on its bus's
  /// `can` section). Throws teleop::Error on a bad config or a port that does not open.
  Cia402JointBus(Cia402JointBusConfig config, std::unique_ptr<Cia402Plant> plant, std::vector<std::string> joint_names);
  ~Cia402JointBus() override;

  int joint_count() const noexcept override { return static_cast<int>(joints_.size()); }
  JointActuator& joint(int i) noexcept override;
  void Configure() override;
  void Activate() override;
  void Deactivate() noexcept override;
  void StartCycle() noexcept override;
  void Exchange(double period_s) noexcept override;
  std::string_view FaultName(std::uint32_t fault_code) const noexcept override;

  // Inspection (tests, telemetry).
  const fieldbus::Cia402Drive& drive(int i) const noexcept;
  /// The host's heartbeat on bus `b` (null when host_heartbeat_period_ms is 0).
  const fieldbus::canopen::HeartbeatProducer* host_heartbeat(int b) const noexcept;
  bool faulted() const noexcept { return faulted_; }
  bool active() const noexcept { return active_; }
  Cia402Plant* plant() noexcept { return plant_.get(); }

 private:
  class Joint;
  std::string Where(std::size_t i) const;
  void Fault() noexcept;
  bool InGrace(std::uint64_t now_ns) noexcept;
  /// Every bus's host heartbeat when due (set-up waits; the cycle's own call latches a refused one).
  void ServiceHeartbeats() noexcept;
  /// Drive `i`'s consumer of the host heartbeat on (the configured time) or off (0), by SDO; throws teleop::Error.
  void SetConsumer(std::size_t i, bool on);
  /// Every drive out of the cycle (Cia402Drive::Deactivate) and its consumer off; errors are the drives' last_error.
  void StopDrives() noexcept;

  Cia402JointBusConfig config_;
  std::unique_ptr<Cia402Plant> plant_;  ///< Before the ports: they are on the plant's buses and go first.
  fieldbus::Timebase timebase_;
  fieldbus::Timebase setup_timebase_;  ///< timebase_ whose waits also send the host heartbeats (the drives' clock).
  std::vector<std::string> names_;
  std::vector<std::unique_ptr<transport::CanPort>> ports_;  ///< One per drive.
  std::vector<std::unique_ptr<fieldbus::Cia402Drive>> drives_;
  std::vector<std::unique_ptr<Joint>> joints_;
  std::vector<std::unique_ptr<fieldbus::canopen::SyncProducer>> syncs_;            ///< One per bus.
  std::vector<std::unique_ptr<fieldbus::canopen::HeartbeatProducer>> heartbeats_;  ///< One per bus (or none).
  std::vector<int> first_joint_of_bus_;
  bool active_ = false;
  bool faulted_ = false;
  bool first_cycle_ = false;
  std::uint64_t grace_end_ns_ = 0;
};

}  // namespace teleop::device::arm
