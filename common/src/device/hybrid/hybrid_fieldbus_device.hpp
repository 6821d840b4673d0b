#pragma once

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "device/hybrid/five_bar.hpp"
#include "device/hybrid/motor_brake_allocation.hpp"
#include "teleop/device/bus_exchange.hpp"
#include "teleop/device/device.hpp"
#include "teleop/fieldbus/can_force_sensor.hpp"
#include "teleop/fieldbus/can_port_config.hpp"
#include "teleop/fieldbus/canopen_sync_producer.hpp"
#include "teleop/fieldbus/cia402_drive.hpp"
#include "teleop/fieldbus/modbus_io_thread.hpp"

namespace teleop::device::hybrid {

/// Where the handle force sensor is read.
enum class ForceSensorBus : std::uint8_t {
  kModbus,  ///< Inputs `force_x_N`, `force_y_N` of the amplifier's register map (same Modbus unit).
  kCan,     ///< A CAN node (fieldbus::CanForceSensor, 2 axes F_x, F_y) on the drives' bus.
};

/// The real rig's driver: two CiA 402 drives in cyclic synchronous torque mode (one per active joint, motor and
/// encoder behind the reducer, the joint 1/pulley_ratio of the drive's shaft angle), a Modbus brake amplifier
/// (outputs `brake_1_Nm`, `brake_2_Nm`: brake shaft torque in N·m; the register map, scaling and unit id are the
/// ModbusConfig's) and the handle force sensor (N, base frame) over Modbus or CAN.
struct HybridFieldbusConfig {
  FiveBarConfig geometry{};
  AllocationConfig allocation{};  ///< Motor and brake limits, pulley ratios, rest threshold.
  /// produce_sync must be false on both: the device produces one SYNC per cycle for the bus (sync_cob_id).
  std::array<fieldbus::Cia402DriveConfig, 2> drives{};
  std::uint32_t sync_cob_id = fieldbus::canopen::cob::kSync;
  /// Joint angle (rad) when the drive's position actual is 0 (homing offset), per joint.
  std::array<double, 2> joint_offset_rad{0.0, 0.0};
  fieldbus::ModbusConfig amplifier{};
  ForceSensorBus force_sensor = ForceSensorBus::kModbus;
  fieldbus::CanForceSensorConfig can_force_sensor{};  ///< When force_sensor is kCan (axes 2).
  /// Activate(): how long to wait for the amplifier's first poll and the CAN force sensor's first frame.
  double activate_timeout_ms = 1000.0;
  /// Readings are relative to this handle position (base frame, m), like the simulated backend.
  Eigen::Vector2d origin_m{0.0, 0.200};
  /// teleop::Error: geometry, allocation, register map (outputs brake_1_Nm, brake_2_Nm with the engaged torque as
  /// safe value; inputs force_x_N, force_y_N when the sensor is on Modbus), node ids, SYNC, the CAN sensor.
  void Validate() const;
};

/// The real rig as `device.hybrid` with `rig: fieldbus` selects it: the device and the CAN medium its ports open on.
struct HybridFieldbusRigConfig {
  HybridFieldbusConfig device{};  ///< geometry, allocation and origin_m come from device.hybrid.
  fieldbus::CanPortConfig can{};
};

/// Which part put the device into its latched safe state (Reading::faults carries the bits).
/// kSync: the cycle's SYNC could not be sent (the bus exchange itself, not either drive).
enum class RigFaultSource : std::uint8_t { kNone, kDrive1, kDrive2, kAmplifier, kForceSensor, kKinematics, kSync };
const char* ToString(RigFaultSource source) noexcept;

/// Device lifecycle: the constructor validates; Configure() opens the CAN ports (when the device owns them: the
/// config constructor), builds the clients, configures both drives (SDO set-up, PDO mapping) and starts the Modbus
/// I/O thread; Activate() brings both drives to Operation Enabled and waits for the amplifier's first poll and the
/// CAN force sensor's first frame (teleop::Error naming the part otherwise).
///
/// The cycle on the bus: Exchange() (the device seam's one bus exchange, teleop/device/bus_exchange.hpp) drains
/// every client (TPDOs sampled at the previous SYNC, the CAN force sensor, the amplifier's newest poll), latching a
/// part that failed under its own name, then sends the one SYNC of the cycle (SendCycleSync: a refused SYNC latches
/// RigFaultSource::kSync); Read() only interprets what it took in (kinematics, no bus I/O); Write() queues both
/// drives' RPDOs. So every SYNC follows both RPDOs of the previous cycle by a period whatever the arbitration, and
/// both drives apply their torque on the same SYNC (canopen_sync_producer.hpp).
///
/// Safe state (latched, until Activate() again): a drive that leaves Operation Enabled, faults, goes stale or loses
/// its heartbeat, an amplifier that stops answering (stale reading), or a CAN force sensor gone stale, puts the
/// motors to zero torque and commands the brakes fully engaged (a brake can only stop motion); the outputs'
/// safe_value is the engaged torque too, so the I/O thread's own command timeout lands in the same state.
/// Deactivate() logs which part latched it.
class HybridFieldbusDevice final : public Device, public BusExchange {
 public:
  /// The device on the given ports (tests): they must outlive it and receive Cia402Drive::ReceiveOptions of their
  /// drive (and CanForceSensor::ReceiveOptions for `sensor_port`, needed when the sensor is on CAN).
  HybridFieldbusDevice(const HybridFieldbusConfig& config, transport::CanPort& drive_1_port,
                       transport::CanPort& drive_2_port,
                       const fieldbus::Timebase& timebase = fieldbus::Timebase::Steady(),
                       transport::CanPort* sensor_port = nullptr);
  /// The device that opens its own ports on `can` at Configure() (one per drive, one for a CAN force sensor).
  HybridFieldbusDevice(const HybridFieldbusConfig& config, const fieldbus::CanPortConfig& can);
  ~HybridFieldbusDevice() override;

  const Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override { return name_; }
  void Configure() override;
  void Activate() override;
  void Deactivate() noexcept override;
  void Exchange() noexcept override;
  void Read(Reading& out) noexcept override;
  void Write(const Command& command) noexcept override;
  void Update(double period_s) noexcept override;
  void SetSafe() noexcept override;

  bool latched_safe() const noexcept { return latched_; }
  RigFaultSource fault_source() const noexcept { return fault_source_.load(std::memory_order_acquire); }
  /// A drive's status that latched the safe state (kDrive1, kDrive2; kOk otherwise).
  fieldbus::Cia402Status fault_status() const noexcept { return fault_status_.load(std::memory_order_relaxed); }
  /// What latched the safe state, in words: the part, its node or COB-ID, what its status says and the key that
  /// bounds it ("drive 2 (node 2): the drive stopped answering (no TPDO for stale_after_ms), 20 ms").
  std::string FaultText() const override;
  std::uint32_t fault_bits() const noexcept { return fault_bits_; }
  const fieldbus::Cia402Drive& drive(int i) const noexcept { return *drives_[static_cast<std::size_t>(i)]; }
  const fieldbus::ModbusIoThread& amplifier() const noexcept { return *amplifier_; }
  const fieldbus::canopen::SyncProducer& sync() const noexcept { return *sync_; }
  const fieldbus::CanForceSensor* force_sensor() const noexcept { return sensor_.get(); }
  const AllocationOutput& last_allocation() const noexcept { return allocation_out_; }

 private:
  void SetCapabilities();
  void Build();
  void WriteDrives(double torque_1_Nm, double torque_2_Nm) noexcept;
  void Latch(RigFaultSource source, std::uint32_t bits,
             fieldbus::Cia402Status status = fieldbus::Cia402Status::kOk) noexcept;
  void CommandSafe() noexcept;
  /// The cycle's one SYNC on the bus (after the TPDOs were drained, long after both RPDOs).
  void SendCycleSync() noexcept;
  /// Exchange's steps: whether the activation-time readings still count as current (starts the grace at the
  /// loop's first cycle); the drives' TPDOs into the joint state; the amplifier's poll and the CAN force sensor.
  bool InGrace(std::uint64_t now_ns) noexcept;
  void TakeInDrives(bool in_grace) noexcept;
  void TakeInAmplifierAndSensor(bool in_grace) noexcept;

  HybridFieldbusConfig config_;
  Capabilities capabilities_;
  std::string name_ = "hybrid";
  FiveBar kinematics_;
  MotorBrakeAllocator allocator_;
  fieldbus::Timebase timebase_;
  std::optional<fieldbus::CanPortConfig> can_;  ///< Set: the device opens (and owns) its ports.
  std::array<std::unique_ptr<transport::CanPort>, 3> owned_ports_;
  std::array<transport::CanPort*, 3> ports_{};  ///< Drive 1, drive 2, force sensor.
  std::array<std::unique_ptr<fieldbus::Cia402Drive>, 2> drives_;
  std::unique_ptr<fieldbus::canopen::SyncProducer> sync_;
  std::unique_ptr<fieldbus::CanForceSensor> sensor_;
  std::unique_ptr<fieldbus::ModbusIoThread> amplifier_;
  std::array<int, 2> brake_output_{0, 1};  // slots in ModbusCommand::values
  std::array<int, 2> force_input_{0, 1};   // slots in ModbusReading::values (Modbus sensor)
  int clutch_input_ = -1;                  // the optional input `clutch` (a pedal on a discrete input); -1: none
  bool clutch_pressed_ = false;            // the input `clutch` as the last Exchange() took it in
  Eigen::Vector2d joint_rad_{0.0, 0.0};
  Eigen::Vector2d joint_velocity_rad_per_s_{0.0, 0.0};
  Eigen::Vector2d hand_force_N_{0.0, 0.0};
  Eigen::Matrix2d jacobian_ = Eigen::Matrix2d::Identity();
  Eigen::Vector2d desired_N_{0.0, 0.0};
  AllocationOutput allocation_out_{};
  bool active_ = false;
  bool latched_ = false;
  bool bad_command_ = false;
  bool first_cycle_ = false;
  std::uint64_t grace_end_ns_ = 0;
  std::array<bool, 3> awaiting_fresh_{};  ///< Drive 1, drive 2, CAN sensor: no fresh reading since Activate().
  // Latched by the cycle, for FaultText on another thread (the event log): the status and EMCY code first, then
  // the source (release), which FaultText reads first (acquire).
  std::atomic<RigFaultSource> fault_source_{RigFaultSource::kNone};
  std::atomic<fieldbus::Cia402Status> fault_status_{fieldbus::Cia402Status::kOk};
  std::atomic<std::uint16_t> fault_emcy_code_{0};  ///< kFault: the drive's newest EMCY code then (0: none).
  std::uint32_t fault_bits_ = kFaultNone;
  double period_s_ = 1e-3;
};

}  // namespace teleop::device::hybrid
