#pragma once

// A CiA 402 drive client over CAN (docs/cia402.md): NMT, expedited SDO set-up, PDO mapping written and read back,
// SYNC producer, heartbeat producer and consumer, EMCY, the CiA 402 state machine to Operation Enabled, and cyclic
// synchronous torque mode (0x6060 = 10). Lifecycle as a device's: Configure() and Activate() at set-up (blocking,
// may throw teleop::Error), Read()/Write() in the control cycle (non-blocking, no allocation, status codes),
// Deactivate() to the safe state.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "teleop/fieldbus/canopen_frames.hpp"
#include "teleop/fieldbus/canopen_pdo.hpp"
#include "teleop/fieldbus/canopen_sdo_client.hpp"
#include "teleop/fieldbus/canopen_timebase.hpp"
#include "teleop/fieldbus/cia402_codec.hpp"
#include "teleop/fieldbus/cia402_state_machine.hpp"
#include "teleop/transport/can_filter.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::fieldbus {

const char* ToString(Cia402Mode mode) noexcept;
/// "position" / "csp" / "8", "velocity" / "csv" / "9", "torque" / "cst" / "10"; false for anything else.
[[nodiscard]] bool ParseCia402Mode(const std::string& text, Cia402Mode& mode) noexcept;

/// Configuration of one drive (a driver's config section fills it).
struct Cia402DriveConfig {
  std::uint8_t node_id = 1;  ///< 1..127.
  canopen::SdoClientConfig sdo{};

  /// SYNC: produced by this client after its RPDO in every Write (one producer per bus; the others set false).
  bool produce_sync = true;
  std::uint32_t sync_cob_id = canopen::cob::kSync;
  double cycle_period_s = 0.001;  ///< Written to 0x1006 (µs); also the period of Activate's polling.

  /// Heartbeat of the host (producer): node-ID `host_node_id` every host_heartbeat_period_ms (0: none).
  std::uint8_t host_node_id = 127;
  double host_heartbeat_period_ms = 100.0;
  /// The drive's heartbeat (written to 0x1017) and the consumer's timeout for it: armed by the first heartbeat
  /// (CiA 301), so the boot itself is timed out separately by boot_timeout_ms.
  double drive_heartbeat_period_ms = 50.0;
  double heartbeat_timeout_ms = 150.0;
  double boot_timeout_ms = 2000.0;  ///< NMT reset → boot-up (or any heartbeat) of the drive.
  /// The drive's own consumer of the host's heartbeat (0x1016 sub 1), so a dead host stops the motor (0: off).
  double drive_consumer_timeout_ms = 0.0;
  /// Send NMT Reset Node at configure and wait for the boot-up (else Reset Communication).
  bool reset_node = true;

  /// PDOs. RPDOs (host → drive) must map 0x6040 (controlword) and 0x6071 (target torque); TPDOs (drive → host)
  /// 0x6041 (statusword), 0x6064 (position actual) and 0x606C (velocity actual), optionally 0x6077 (torque actual).
  /// Written at configure (disable, mapping, count, COB-ID, type) and read back; a mismatch is an error.
  std::vector<canopen::PdoMapping> rpdos = DefaultRpdos();
  std::vector<canopen::PdoMapping> tpdos = DefaultTpdos();

  /// The mode written to 0x6060 and checked against 0x6502. With rpdos left at the torque default, another mode
  /// takes its own default RPDO (DefaultRpdos(mode)).
  Cia402Mode mode = Cia402Mode::kCyclicSynchronousTorque;
  Cia402Scaling scaling{};
  double max_torque_Nm = 0.5;  ///< Written to 0x6072; Write also clamps to it (counted).
  /// Velocity mode: Write clamps the target velocity to it; position mode: the target moves at most
  /// max_velocity_rad_per_s · cycle_period_s per Write (both counted). 0: no clamp.
  double max_velocity_rad_per_s = 0.0;
  /// 0x605D (1..4: how halt stops the motor), written when set.
  std::optional<std::int16_t> halt_option_code{};
  /// 0x605A and 0x605E, written when set (what quick stop and a fault do is the drive's; the field notes).
  std::optional<std::int16_t> quick_stop_option_code{};
  std::optional<std::int16_t> fault_reaction_option_code{};

  double state_timeout_ms = 500.0;  ///< Activate: time allowed for each state machine step.
  /// Read: data older than this (no TPDO since) is a fault (kStale); a missed TPDO before that is kNoNewData.
  double stale_after_ms = 10.0;
  /// Configure reads the identity, device name, versions and error history (ReadDeviceInfo) and logs them.
  bool read_device_info = true;
  /// The drive's EDS/DCF (CiA 306): ApplyEds (cia402_eds.hpp) takes default COB-IDs from it, and it and Configure
  /// check every object the client uses against it (type, access, PDO mapping, capacity). Empty: no check.
  std::string eds_file;

  /// RPDO1 = controlword + target torque (4 bytes); TPDO1 = statusword + position actual (6 bytes), TPDO2 = velocity
  /// actual + torque actual (6 bytes); synchronous (type 1), default COB-IDs.
  static std::vector<canopen::PdoMapping> DefaultRpdos();
  static std::vector<canopen::PdoMapping> DefaultTpdos();
  /// RPDO1 = controlword + the mode's target: 0x607A (32 bits, 6 bytes), 0x60FF (32 bits, 6 bytes) or 0x6071
  /// (16 bits, 4 bytes: DefaultRpdos()).
  static std::vector<canopen::PdoMapping> DefaultRpdos(Cia402Mode mode);
};

/// What Read/Write report (the cycle's status; a device maps it onto its fault flags).
enum class Cia402Status : std::uint8_t {
  kOk = 0,
  kNoNewData,      ///< No TPDO since the last Read, not yet stale: the reading is the previous one.
  kStale,          ///< No TPDO for stale_after_ms.
  kNotEnabled,     ///< The drive left Operation Enabled (its statusword says where it is).
  kFault,          ///< The drive is in Fault / Fault Reaction Active, or sent an EMCY since activation.
  kHeartbeatLost,  ///< No heartbeat for heartbeat_timeout_ms (after the first one).
  kBusOff,         ///< The controller is bus-off.
  kWriteFailed,    ///< The port refused a frame (buffer full, error).
  kNotActive,      ///< Called before Activate() or after Deactivate().
  kWrongMode,      ///< A setpoint of another mode than the configured one: the hold target was sent instead.
};
const char* ToString(Cia402Status status) noexcept;
/// What a status other than kOk/kNoNewData says failed, in an operator's words, naming the drive's config keys
/// (stale_after_ms, heartbeat_timeout_ms) where one bounds it: the backends' Device::FaultText.
const char* Describe(Cia402Status status) noexcept;
/// Describe(status) with the bound that tripped it (", 50 ms" for kStale and kHeartbeatLost, from `config`) and,
/// for kFault with a non-zero `emcy_code`, the EMCY's code and CiA 301 meaning. Allocates: not for the cycle (a
/// backend latches the status and the code in the cycle and calls this from Device::FaultText).
std::string DescribeFault(const Cia402DriveConfig& config, Cia402Status status, std::uint16_t emcy_code);

/// One cycle's reading, SI units. `stamp_ns` is when the TPDOs carrying it were read (Timebase clock).
struct Cia402Reading {
  double position_rad = 0.0;
  double velocity_rad_per_s = 0.0;
  double torque_Nm = 0.0;  ///< 0x6077 when mapped, else the commanded torque.
  std::uint16_t statusword = 0;
  cia402::DriveState state = cia402::DriveState::kUnknown;
  std::uint64_t stamp_ns = 0;
  bool fresh = false;  ///< New since the last Read.
};

/// What a drive says about itself (CiA 301 0x1000, 0x1018, 0x1008, 0x1009, 0x100A, 0x1003; CiA 402 0x6502). The
/// strings are read by segmented SDO when longer than 4 bytes; an optional object the drive lacks (aborted with
/// 0x0602xxxx, 0x0609xxxx or 0x0601xxxx) is left empty and its `*_present` false.
struct Cia402DeviceInfo {
  std::uint32_t device_type = 0;
  std::uint32_t vendor_id = 0, product_code = 0, revision = 0, serial = 0;
  bool identity_present = false;
  std::string device_name, hardware_version, software_version;
  bool device_name_present = false, hardware_version_present = false, software_version_present = false;
  std::uint32_t supported_modes = 0;  ///< 0x6502 (bit m - 1 for mode m 1..7; bit 7, 8, 9 for modes 8, 9, 10).
  bool supported_modes_present = false;
  /// 0x1003 sub 1..n, newest first: error code in bits 0..15, manufacturer information in 16..31.
  std::vector<std::uint32_t> error_history;
  bool error_history_present = false;
  /// One line per item ("device name 'x'", "error history: 0x2310 (1 of 1)").
  std::string Describe() const;
};

/// What the client counted.
struct Cia402Counters {
  std::uint64_t rpdos_sent = 0;
  std::uint64_t syncs_sent = 0;
  /// Writes within half a cycle period of the last SYNC (a late loop's catch-up): nothing sent (CiA 301 SYNC
  /// period 0x1006; a CSP drive would otherwise take two targets in one of its cycles).
  std::uint64_t syncs_skipped = 0;
  std::uint64_t heartbeats_sent = 0;
  std::uint64_t tpdos_received = 0;
  std::uint64_t tpdos_rejected = 0;  ///< Wrong length for the mapping.
  std::uint64_t heartbeats_received = 0;
  std::uint64_t heartbeat_timeouts = 0;
  std::uint64_t emergencies = 0;
  std::uint64_t error_frames = 0;
  std::uint64_t bus_off = 0;
  std::uint64_t write_failures = 0;
  std::uint64_t torque_clamped = 0;
  std::uint64_t non_finite_commands = 0;  ///< NaN/inf torque commands: sent as 0.
  std::uint64_t state_changes = 0;
  std::uint64_t other_frames = 0;           ///< Frames on the port that are not this drive's.
  std::uint64_t velocity_clamped = 0;       ///< Velocity targets clamped to max_velocity_rad_per_s.
  std::uint64_t position_step_clamped = 0;  ///< Position targets that moved faster than max_velocity_rad_per_s.
  std::uint64_t wrong_mode_setpoints = 0;   ///< Setpoints of another mode (kWrongMode).
};

class Cia402Drive {
 public:
  /// Checks the configuration (throws teleop::Error naming the key) and keeps `port`, which must outlive the
  /// client and should receive ReceiveOptions(config) (OpenCanPort / EmulatedCanBus::MakePort). No bus traffic.
  Cia402Drive(const Cia402DriveConfig& config, transport::CanPort& port, Timebase timebase = Timebase::Steady());
  ~Cia402Drive();
  Cia402Drive(const Cia402Drive&) = delete;
  Cia402Drive& operator=(const Cia402Drive&) = delete;

  /// The filters a port for this drive needs: its TPDOs, SDO responses, EMCY, heartbeat (classic frames).
  static transport::CanReceiveOptions ReceiveOptions(const Cia402DriveConfig& config);

  /// Set-up: NMT reset (node or communication), waits for the boot-up (boot_timeout_ms), checks the device type,
  /// writes the heartbeat times, the cycle period, the PDO mappings (and reads them back), mode 10, max torque,
  /// option codes, the rated torque check. The drive stays pre-operational. Throws teleop::Error with the object and
  /// the decoded SDO abort code, the timeout, or the mismatch.
  void Configure();
  /// Set-up: NMT Start, target torque 0, then the state machine to Operation Enabled by SDO on 0x6040/0x6041, with a
  /// fault reset (rising edge of bit 7) when the drive is in Fault; reads 0x1001/0x603F when it faults. Throws
  /// teleop::Error with the state it got stuck in. After it, Read/Write run the cycle.
  void Activate();
  /// Cycle: drains the port (TPDOs, heartbeat, EMCY, error frames), checks the heartbeat and staleness, fills
  /// `reading` with the newest values. Non-blocking, no allocation.
  [[nodiscard]] Cia402Status Read(Cia402Reading& reading) noexcept;
  /// Cycle: sends the RPDOs (controlword + the mode's target), then the SYNC (produce_sync) and the host heartbeat
  /// when due; each setpoint carries its unit. Torque (CST) clamped to max_torque_Nm, velocity (CSV) to
  /// max_velocity_rad_per_s, NaN → 0; position (CSP): NaN, a fault, a lost heartbeat or a quick stop hold the last
  /// target, the step per SYNC clamped to max_velocity_rad_per_s · cycle_period_s. A setpoint of another mode than
  /// the configured one sends the hold target (WriteHold) and returns kWrongMode (counted). Within half a cycle
  /// period of its last SYNC (produce_sync) nothing is sent (counted in syncs_skipped): no SYNC burst when a late
  /// loop catches up. Non-blocking, no allocation.
  [[nodiscard]] Cia402Status WriteTorque_Nm(double torque_Nm) noexcept;
  [[nodiscard]] Cia402Status WriteVelocity_rad_per_s(double velocity_rad_per_s) noexcept;
  [[nodiscard]] Cia402Status WritePosition_rad(double position_rad) noexcept;
  /// Cycle: the mode's target that holds the joint: torque 0, velocity 0, or the last position target.
  [[nodiscard]] Cia402Status WriteHold() noexcept;
  /// Cycle: from the next Write on, the controlword commands Quick Stop (bit 2 = 0) and the torque is 0.
  void RequestQuickStop() noexcept;
  /// Cycle: from the next Write on, controlword bit 8 (halt) is `halt`: the drive stops by 0x605D and holds, staying
  /// in Operation Enabled (statusword bit 10 once at rest); clearing it resumes the targets.
  void RequestHalt(bool halt) noexcept { halt_requested_ = halt; }
  /// The last target sent in position mode (rad), e.g. to start a jog from it.
  double position_target_rad() const noexcept { return position_target_rad_; }
  /// Set-up (safe state): torque 0, Disable Operation then Shutdown by SDO, NMT Enter Pre-operational. Never throws;
  /// returns false (and keeps the reason in last_error()) when the drive did not confirm.
  bool Deactivate() noexcept;

  /// Set-up: reads the error register 0x1001 by SDO (throws on failure).
  std::uint8_t ReadErrorRegister();
  /// Set-up: reads the device type, identity, name, versions, supported modes and error history (Cia402DeviceInfo);
  /// optional objects the drive lacks are left empty, a timeout throws. Configure calls it (read_device_info) and
  /// logs the result; it is kept in device_info().
  const Cia402DeviceInfo& ReadDeviceInfo();
  const Cia402DeviceInfo& device_info() const noexcept { return info_; }
  /// The set-up SDO client (teleop-drive's `sdo read|write`; never in the cycle).
  canopen::SdoClient& sdo() noexcept { return sdo_; }

  bool active() const noexcept { return active_; }
  cia402::DriveState drive_state() const noexcept { return drive_state_; }
  canopen::NmtState nmt_state() const noexcept { return nmt_state_; }
  bool heartbeat_armed() const noexcept { return heartbeat_seen_; }
  /// The newest EMCY since Configure (error_code 0 when none arrived).
  const canopen::Emergency& last_emergency() const noexcept { return last_emergency_; }
  const Cia402Counters& counters() const noexcept { return counters_; }
  const canopen::SdoClientCounters& sdo_counters() const noexcept { return sdo_.counters(); }
  const Cia402DriveConfig& config() const noexcept { return config_; }
  const std::string& last_error() const noexcept { return last_error_; }
  std::string Describe() const;

 private:
  void HandleFrame(const proto::can::CanFrame& frame) noexcept;
  void ServiceSetup() noexcept;
  bool SendHeartbeatIfDue(std::uint64_t now_ns) noexcept;
  void WaitForBoot();
  // Configure's steps, in order (each throws teleop::Error).
  std::string ConfigureWhere() const;
  void CheckEds() const;
  void ResetAndWaitForBoot();
  void CheckIdentity();
  /// Heartbeat producer and consumer, COB-ID SYNC, cycle period; `consumer_armed` true as soon as the drive's
  /// consumer is armed (so that a failure after it, here or later, undoes it).
  void WriteCommunicationObjects(bool& consumer_armed);
  void WritePdos();
  void SelectMode();
  void WriteLimits();
  void WritePdo(const canopen::PdoMapping& mapping, bool tpdo);
  /// The mode's target that holds the joint: torque 0, velocity 0, or position = the actual position (by SDO).
  void WriteHoldTarget();
  void SetDriveState(cia402::DriveState state) noexcept;
  [[nodiscard]] bool HeartbeatExpired(std::uint64_t now_ns) noexcept;
  // The cycle's transmit: the mode's target in drive units (clamped, counted), then RPDOs + SYNC + heartbeat.
  bool HoldTargets() const noexcept;
  std::uint32_t TorqueTarget(double torque_Nm) noexcept;
  std::uint32_t VelocityTarget(double velocity_rad_per_s) noexcept;
  std::uint32_t PositionTarget(double position_rad) noexcept;
  Cia402Status WrongMode() noexcept;
  Cia402Status Transmit(std::uint32_t target_raw) noexcept;
  bool SendRpdos(std::uint32_t target_raw) noexcept;
  bool SendSync(std::uint64_t now_ns) noexcept;

  Cia402DriveConfig config_;
  transport::CanPort& port_;
  Timebase timebase_;
  canopen::SdoClient sdo_;
  Cia402PdoLayout layout_{};       ///< The PDOs (cia402_codec.hpp), checked at construction.
  Cia402PdoValues tpdo_values_{};  ///< The newest raw value of every TPDO entry.
  std::array<std::uint64_t, 4> tpdo_stamp_ns_{};
  bool halt_requested_ = false;
  double position_target_rad_ = 0.0;
  unsigned tpdo_seen_mask_ = 0;  ///< TPDOs received since the last Read (bit per slot).
  bool configured_ = false;
  bool heartbeat_lost_ = false;
  bool sync_sent_ = false;  ///< A SYNC went out since Activate (last_sync_ns_ is valid).
  std::uint64_t last_sync_ns_ = 0;
  std::uint64_t half_period_ns_ = 0;

  bool active_ = false;
  bool quick_stop_requested_ = false;
  bool bus_off_ = false;
  bool fault_latched_ = false;
  bool heartbeat_seen_ = false;
  bool boot_seen_ = false;
  std::uint64_t last_heartbeat_ns_ = 0;
  std::uint64_t next_host_heartbeat_ns_ = 0;
  std::uint16_t statusword_ = 0;
  std::uint16_t controlword_ = 0;
  double commanded_torque_Nm_ = 0.0;
  double pending_torque_Nm_ = 0.0;  ///< The target of the Write in progress (kept only when it is sent).
  double pending_position_rad_ = 0.0;
  cia402::DriveState drive_state_ = cia402::DriveState::kUnknown;
  canopen::NmtState nmt_state_ = canopen::NmtState::kBootUp;
  canopen::Emergency last_emergency_{};
  Cia402Reading newest_{};
  Cia402Counters counters_{};
  std::string last_error_;
  Cia402DeviceInfo info_{};
};

}  // namespace teleop::fieldbus
