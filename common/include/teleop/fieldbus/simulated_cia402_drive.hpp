#pragma once

// A simulated CiA 402 drive on a CAN port (docs/cia402.md, "Simulated drive"): the same bytes a real drive speaks,
// so the client under test is the client in use. A joint with inertia, viscous and Coulomb friction and a
// first-order torque lag; its own NMT state machine, SDO server (expedited and segmented) for the objects the client
// uses, PDOs on SYNC, heartbeat producer, a consumer of the host's heartbeat, EMCY on fault. Fault injection for tests.

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "teleop/fieldbus/canopen_frames.hpp"
#include "teleop/fieldbus/canopen_pdo.hpp"
#include "teleop/fieldbus/canopen_sdo.hpp"
#include "teleop/fieldbus/cia402_state_machine.hpp"
#include "teleop/transport/can_filter.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::fieldbus {

/// The joint the drive moves: J·dω/dt = τ_applied − b·ω − τ_c·sign(ω) (sticks while |τ| ≤ τ_c at rest), and
/// τ_applied follows the commanded torque with time constant torque_lag_s.
struct SimulatedJointConfig {
  double inertia_kg_m2 = 1e-3;
  double viscous_Nms_per_rad = 2e-3;
  double coulomb_Nm = 5e-3;
  double torque_lag_s = 5e-4;
  double integration_step_s = 1e-4;  ///< Sub-step of the joint's integration.
  /// The joint is moved from outside (SetJointState each step; an arm's dynamics, simulated_cia402_arm.hpp): the
  /// drive runs its loops and torque lag only, and applied_torque_Nm() is what it puts on the shaft.
  bool external_shaft = false;
};

/// The drive's own control loops (cyclic synchronous position and velocity, CiA 402 modes 8 and 9), run at the
/// joint's integration step (10 kHz by default) as a drive's loops run far faster than SYNC: a PI velocity loop
/// τ = kv (ω_ref − ω) + ki ∫(ω_ref − ω) dt (clamped to 0x6072; the integral held while clamped) and, in position mode,
/// a P position loop ω_ref = kp (θ_target − θ). With the velocity loop much faster than kp, θ/θ_target ≈ kp / (s + kp):
/// the position loop's bandwidth is kp (100 rad/s by default, against J = 1e-3 kg·m²: velocity loop ≈ kv / J = 600
/// rad/s).
struct SimulatedLoopConfig {
  double velocity_kp_Nms_per_rad = 0.6;
  double velocity_ki_Nm_per_rad = 12.0;  ///< The PI zero at ki / kv = 20 rad/s, well below kp.
  double position_kp_per_s = 100.0;
  double standstill_rad_per_s = 0.05;  ///< Quick stop / halt: at rest below this speed.
};

/// Loops as a lab drive is tuned (position-loop bandwidth 100–400 Hz, i.e. 600–2500 rad/s), for `bandwidth_rad_per_s`
/// on `joint`: kp = the bandwidth, the velocity loop 5 times faster (kv = 5 · bandwidth · J), its PI zero at
/// bandwidth / 5. A velocity loop that fast needs a faster torque lag and integration step than the defaults, so
/// `joint` gets torque_lag_s = 0.02 / bandwidth and integration_step_s = min(1e-4, 0.02 / bandwidth). The defaults of
/// SimulatedLoopConfig and SimulatedJointConfig (kp = 100 rad/s) are unchanged.
inline SimulatedLoopConfig LoopsForBandwidth(double bandwidth_rad_per_s, SimulatedJointConfig& joint) noexcept {
  SimulatedLoopConfig l;
  l.position_kp_per_s = bandwidth_rad_per_s;
  l.velocity_kp_Nms_per_rad = 5.0 * bandwidth_rad_per_s * joint.inertia_kg_m2;
  l.velocity_ki_Nm_per_rad = l.velocity_kp_Nms_per_rad * bandwidth_rad_per_s / 5.0;
  joint.torque_lag_s = 0.02 / bandwidth_rad_per_s;
  joint.integration_step_s = std::min(1e-4, 0.02 / bandwidth_rad_per_s);
  return l;
}

struct SimulatedCia402DriveConfig {
  std::uint8_t node_id = 1;
  SimulatedJointConfig joint{};
  std::uint32_t rated_torque_mNm = 1000;         ///< 0x6076.
  double position_rad_per_count = 1.0 / 4096.0;  ///< The drive's position unit.
  double velocity_rad_per_s_per_unit = 1.0 / 4096.0;
  std::uint16_t max_torque_per_mille = 1000;  ///< 0x6072 at power-on.
  double boot_time_ms = 5.0;                  ///< Power-on / reset node → boot-up message.
  std::uint16_t heartbeat_period_ms = 0;      ///< 0x1017 at power-on (0: no heartbeat until written).
  std::uint32_t vendor_id = 0x0000'0A5A;      ///< 0x1018 sub 1.
  /// 0x6502: cyclic synchronous position, velocity and torque (bits 7, 8, 9).
  std::uint32_t supported_modes = 0x0000'0380;
  SimulatedLoopConfig loops{};
  /// 0x6084 / 0x6085 at power-on, rad/s² (the dictionary holds them in velocity units per second).
  double profile_deceleration_rad_per_s2 = 200.0;
  double quick_stop_deceleration_rad_per_s2 = 2000.0;
  /// 0x1008 / 0x1009 / 0x100A (VISIBLE_STRING, served segmented when longer than 4 bytes; at most 64 bytes).
  std::string device_name = "teleop simulated CiA 402 drive";
  std::string hardware_version = "sim 1";
  std::string software_version = "teleop 1.0";
  /// The SDO server aborts a segmented transfer with 0x05040000 when the client is silent this long.
  double sdo_server_timeout_ms = 1000.0;
  /// 0x6061 shows a new 0x6060 this long after the write (drives switch modes in their own cycle; 0: at once).
  double mode_display_delay_ms = 0.0;
};

/// What the simulated drive counted (for tests).
struct SimulatedDriveCounters {
  std::uint64_t sdo_requests = 0;
  std::uint64_t sdo_aborts_sent = 0;
  std::uint64_t syncs = 0;
  std::uint64_t rpdos = 0;
  std::uint64_t rpdos_rejected = 0;  ///< Wrong length for the mapping: EMCY 0x8210.
  std::uint64_t tpdos_sent = 0;
  std::uint64_t heartbeats_sent = 0;
  std::uint64_t emergencies_sent = 0;
  std::uint64_t nmt_commands = 0;
  std::uint64_t host_heartbeat_timeouts = 0;
  std::uint64_t fault_resets = 0;
  std::uint64_t sdo_segments = 0;  ///< Segments served (upload) or taken (download).
};

class SimulatedCia402Drive {
 public:
  /// Powers on at the first Step() (boot-up after boot_time_ms). `port` must outlive the drive and should receive
  /// ReceiveOptions(config).
  SimulatedCia402Drive(const SimulatedCia402DriveConfig& config, transport::CanPort& port);
  ~SimulatedCia402Drive();
  SimulatedCia402Drive(const SimulatedCia402Drive&) = delete;
  SimulatedCia402Drive& operator=(const SimulatedCia402Drive&) = delete;

  /// What the drive must receive: NMT, SYNC (0x080), its SDO requests, every RPDO COB-ID it could be given, and
  /// heartbeats (for its consumer).
  static transport::CanReceiveOptions ReceiveOptions(const SimulatedCia402DriveConfig& config);

  /// Advances the drive to `now_ns`: reads and answers every pending frame (in order), integrates the joint, sends
  /// the heartbeat when due and TPDOs after each SYNC. Call it often (at least every SYNC period). No allocation.
  void Step(std::uint64_t now_ns) noexcept;

  // ---- Fault injection ----
  /// Stops answering anything (SDO, PDO, heartbeat, boot-up): a dead or unplugged drive. Frames are still read.
  void SetSilent(bool silent) noexcept;
  /// A drive fault: leaves Operation Enabled through Fault Reaction Active to Fault, sends EMCY `error_code` with
  /// the error register set (0x1001), keeps 0x603F. A fault reset (controlword bit 7 rising) clears it and sends
  /// EMCY 0x0000.
  void InjectFault(std::uint16_t error_code) noexcept;
  /// Leaves Operation Enabled without a fault (as a drive does on an external disable / STO input): to Switch On
  /// Disabled.
  void ForceDisable() noexcept;
  /// Stops (or resumes) only the heartbeat; everything else goes on.
  void SetHeartbeatMuted(bool muted) noexcept;
  /// The next `count` SDO requests get no response (the client must retry).
  void DropSdoResponses(int count) noexcept;
  /// Every SDO access to `index` is aborted with `abort_code` (0 clears; up to 8 objects at a time, e.g. the
  /// objects a smaller drive lacks, with 0x06020000).
  void AbortObject(std::uint16_t index, std::uint32_t abort_code) noexcept;
  /// SDO requests for `index` get no answer at all (a node that answers only some SDOs; 0 clears).
  void IgnoreObject(std::uint16_t index) noexcept { ignore_index_ = index; }
  /// Moves the joint (test set-up).
  void SetJointState(double position_rad, double velocity_rad_per_s) noexcept;
  /// An external torque on the joint (the environment), N·m.
  void SetExternalTorque(double torque_Nm) noexcept;

  // ---- Observation ----
  cia402::DriveState drive_state() const noexcept { return machine_.state(); }
  canopen::NmtState nmt_state() const noexcept { return nmt_; }
  std::int8_t mode_of_operation() const noexcept { return mode_; }
  double position_rad() const noexcept { return position_rad_; }
  double velocity_rad_per_s() const noexcept { return velocity_rad_per_s_; }
  double applied_torque_Nm() const noexcept { return applied_torque_Nm_; }
  double commanded_torque_Nm() const noexcept;
  std::uint8_t error_register() const noexcept { return error_register_; }
  std::uint16_t error_code() const noexcept { return error_code_; }
  /// 0x1016:01, its consumer of the host's heartbeat (CiA 301: node-ID << 16 | time in ms; 0 off).
  std::uint32_t consumer_heartbeat() const noexcept;
  const SimulatedDriveCounters& counters() const noexcept { return counters_; }
  /// The mapping a PDO has now (n 1..4), as the object dictionary holds it.
  const canopen::PdoMapping& rpdo(int n) const noexcept;
  const canopen::PdoMapping& tpdo(int n) const noexcept;

 private:
  struct Dictionary;
  void Boot(std::uint64_t now_ns) noexcept;
  void HandleFrame(const proto::can::CanFrame& frame, std::uint64_t now_ns) noexcept;
  void HandleSdo(const proto::can::CanFrame& frame, std::uint64_t now_ns) noexcept;
  void HandleSdoSegment(const canopen::SdoMessage& m, std::uint64_t now_ns) noexcept;
  /// Answers an upload of a byte-string object: expedited up to 4 bytes, else the segmented transfer starts.
  void UploadBytes(const canopen::SdoMessage& m, std::span<const std::uint8_t> bytes, std::uint64_t now_ns) noexcept;
  void SendSdoAbort(std::uint16_t index, std::uint8_t subindex, std::uint32_t code) noexcept;
  /// The object dictionary access of one expedited-sized value: 0 (and the value read) or the abort code.
  std::uint32_t Access(const canopen::SdoMessage& m, std::uint32_t& out_value, std::uint8_t& out_size) noexcept;
  struct ObjectAccess;
  /// One row of the object dictionary: the objects first..last and the function that serves them.
  struct ObjectRange {
    std::uint16_t first = 0;
    std::uint16_t last = 0;
    std::uint32_t (SimulatedCia402Drive::*access)(const ObjectAccess&) noexcept = nullptr;
  };
  static const std::array<ObjectRange, 6> kDictionary;
  /// An AccessDriveControl answer for an object it does not serve (not an abort code: those have bit 31 clear or
  /// are 0x05..0x08 in the top byte).
  static constexpr std::uint32_t kNotServed = 0xFFFF'FFFFu;
  std::uint32_t AccessRpdoCommunication(const ObjectAccess& a) noexcept;
  std::uint32_t AccessTpdoCommunication(const ObjectAccess& a) noexcept;
  std::uint32_t AccessPdoCommunication(const ObjectAccess& a, bool tpdo) noexcept;
  std::uint32_t AccessPdoMapping(const ObjectAccess& a) noexcept;
  std::uint32_t AccessCommunication(const ObjectAccess& a) noexcept;
  std::uint32_t AccessDrive(const ObjectAccess& a) noexcept;
  std::uint32_t AccessDriveControl(const ObjectAccess& a) noexcept;
  std::uint32_t AccessDriveValues(const ObjectAccess& a) noexcept;
  /// The byte-string objects (0x1008, 0x1009, 0x100A, 0x2000 the writable label): false for any other object.
  bool ByteObject(std::uint16_t index, std::uint8_t subindex, std::span<const std::uint8_t>& bytes,
                  bool& writable) const noexcept;
  void StoreLabel(std::span<const std::uint8_t> bytes) noexcept;
  void FlushResetEmergency() noexcept;
  void HandleSync() noexcept;
  void HandleRpdo(int n, const proto::can::CanFrame& frame) noexcept;
  void Integrate(std::uint64_t now_ns) noexcept;
  void Send(const proto::can::CanFrame& frame) noexcept;
  void EnterFault(std::uint16_t error_code) noexcept;
  std::uint16_t Statusword() const noexcept;
  /// The torque the drive's loops command over one integration step of `h` seconds.
  double LoopTorque(double h) noexcept;
  double VelocityLoop(double velocity_ref, double h) noexcept;
  double TorqueLimit_Nm() const noexcept;

  SimulatedCia402DriveConfig config_;
  transport::CanPort& port_;
  std::unique_ptr<Dictionary> dict_;
  cia402::DriveStateMachine machine_{};
  canopen::NmtState nmt_ = canopen::NmtState::kBootUp;
  bool powered_ = false;
  bool booted_ = false;
  bool silent_ = false;
  bool heartbeat_muted_ = false;
  int drop_sdo_ = 0;
  struct AbortedObject {
    std::uint16_t index = 0;  ///< 0: unused.
    std::uint32_t code = 0;
  };
  std::array<AbortedObject, 8> aborted_{};
  std::uint16_t ignore_index_ = 0;
  std::uint64_t boot_at_ns_ = 0;
  std::uint64_t last_ns_ = 0;
  std::uint64_t next_heartbeat_ns_ = 0;
  std::uint64_t host_heartbeat_ns_ = 0;
  bool host_heartbeat_seen_ = false;
  std::int8_t mode_ = 0;
  std::int8_t previous_display_ = 0;      ///< 0x6061 until mode_display_at_ns_.
  std::uint64_t mode_display_at_ns_ = 0;  ///< From then on 0x6061 shows mode_.
  std::int8_t DisplayedMode() const noexcept { return last_ns_ >= mode_display_at_ns_ ? mode_ : previous_display_; }
  std::uint16_t controlword_ = 0;
  std::int16_t target_torque_ = 0;
  std::int16_t pending_target_torque_ = 0;
  std::int32_t target_position_ = 0;
  std::int32_t target_velocity_ = 0;
  std::int32_t pending_target_position_ = 0;
  std::int32_t pending_target_velocity_ = 0;
  double velocity_integral_Nm_ = 0.0;
  double command_Nm_ = 0.0;  ///< What the loops commanded in the last step.
  bool stopping_ = false;    ///< Quick stop or halt in progress (ramping or holding).
  bool holding_ = false;     ///< At rest after a quick stop or halt: the position loop holds hold_position_rad_.
  double stop_velocity_ref_ = 0.0;
  double hold_position_rad_ = 0.0;
  std::uint16_t pending_controlword_ = 0;
  bool pending_rpdo_ = false;
  std::uint8_t error_register_ = 0;
  std::uint16_t error_code_ = 0;
  double position_rad_ = 0.0;
  double velocity_rad_per_s_ = 0.0;
  double applied_torque_Nm_ = 0.0;
  double external_torque_Nm_ = 0.0;
  SimulatedDriveCounters counters_{};

  /// The SDO server's segmented transfer in progress (CiA 301 §7.2.4.3.3-6): one at a time, fixed buffer.
  struct SdoTransfer {
    enum class Phase : std::uint8_t { kIdle, kUpload, kDownload };
    Phase phase = Phase::kIdle;
    std::uint16_t index = 0;
    std::uint8_t subindex = 0;
    bool toggle = false;
    bool size_indicated = false;
    std::size_t size = 0;      ///< Upload: the bytes to send; download: the size indicated.
    std::size_t offset = 0;    ///< Bytes sent / received so far.
    std::size_t capacity = 0;  ///< Download: the object's largest size.
    std::uint64_t last_ns = 0;
    std::array<std::uint8_t, 64> buffer{};
  };
  SdoTransfer transfer_{};
  bool reset_emcy_pending_ = false;
  std::array<std::uint32_t, 8> error_history_{};  ///< 0x1003 sub 1..8, newest first.
  std::uint8_t error_history_count_ = 0;
  std::array<std::uint8_t, 32> label_{};  ///< 0x2000 (manufacturer-specific VISIBLE_STRING, read-write).
  std::array<std::array<std::uint8_t, 64>, 3> strings_{};  ///< 0x1008, 0x1009, 0x100A.
  std::array<std::size_t, 3> string_sizes_{};
  std::size_t label_size_ = 0;
};

}  // namespace teleop::fieldbus
