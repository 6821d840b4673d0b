#pragma once

#include <atomic>
#include <memory>
#include <string>

#include "device/cobot/cobot_backend.hpp"
#include "device/cobot/cobot_fieldbus_config.hpp"
#include "device/cobot/cobot_sensor_node.hpp"
#include "device/cobot/cobot_steering_drive.hpp"
#include "device/cobot/master_walls.hpp"
#include "device/cobot/rate_estimator.hpp"
#include "device/cobot/virtual_wall.hpp"
#include "teleop/fieldbus/can_force_sensor.hpp"

namespace teleop::device::cobot {

/// The real unicycle cobot behind the Device interface (`device.cobot.rig: fieldbus`): the same controllers and
/// master walls as the simulated rig, on measured signals.
///  - Steering angle ψ from the CiA 402 drive's position actual value (CobotSteeringDrive), plus
///    steering_offset_rad: the cart does not rotate (the xy frame holds it), so ψ is the heading.
///  - Wheel travel from the sensor node (CobotSensorNode) and the handle force from its force TPDO, read by the
///    generic teleop::fieldbus::CanForceSensor; the position is integrated from the wheel travel along ψ (odometry,
///    from initial_position_m): the rig has no absolute position sensor on the bus.
///  - u and ω by the same digital differentiation and filtering as the simulated rig (§3.2).
///  - The steering torque of the controller goes to the drive at each Write (RPDO, then the SYNC that also makes
///    the sensor node send its TPDOs).
///
/// Steering faults stop the cobot (latched until Activate()): a lost drive, a heartbeat timeout or a drive fault
/// leave the steering with no torque (nothing turns the wheel off its current tangent); an encoder jump holds the
/// encoder where it is (CobotSteeringDrive); in both cases the wheel brake is engaged where the rig has one
/// (brake_max_force_N > 0: the sensor node's brake output). A lost sensor node, a wheel encoder jump, a stale or
/// invalid force reading (latched too), a bad Command or SetSafe() (until the next good Command) lock the steering
/// on its current heading (Γ = −K₂ω) and engage the brake. Reading::faults carries kFaultCommunication (lost drive,
/// heartbeat, lost node) or kFaultDriver (drive fault, encoder jumps; a bad Command once) while the latch holds.
class UnicycleCobotFieldbusDevice final : public Device {
 public:
  /// Opens its three ports (drive, wheel/brake, force) on config.fieldbus.can at Configure().
  explicit UnicycleCobotFieldbusDevice(const CobotBackendConfig& config,
                                       fieldbus::Timebase timebase = fieldbus::Timebase::Steady());
  /// On the given ports (tests: the in-process emulated bus). They must outlive the device and receive
  /// fieldbus::Cia402Drive::ReceiveOptions(config.fieldbus.steering.drive),
  /// CobotSensorNode::ReceiveOptions(config.fieldbus.sensors) and
  /// fieldbus::CanForceSensor::ReceiveOptions(config.fieldbus.sensors.ForceSensorConfig()).
  UnicycleCobotFieldbusDevice(const CobotBackendConfig& config, transport::CanPort& drive_port,
                              transport::CanPort& sensor_port, transport::CanPort& force_port,
                              fieldbus::Timebase timebase = fieldbus::Timebase::Steady());
  ~UnicycleCobotFieldbusDevice() override;

  const Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override { return name_; }
  void Configure() override;
  void Activate() override;
  void Deactivate() noexcept override;
  void Read(Reading& out) noexcept override;
  void Write(const Command& command) noexcept override;
  void Update(double period_s) noexcept override;
  void SetSafe() noexcept override;

  bool locked() const noexcept;
  SteeringFault steering_fault() const noexcept;
  SensorFault sensor_fault() const noexcept;
  /// The first steering and sensor faults since Activate in words, with the node and the key that bounds each
  /// ("the steering drive (node 5) stopped answering (no TPDO for stale_after_ms, 10 ms)"). Any thread.
  std::string FaultText() const override;
  bool brake_engaged() const noexcept { return brake_engaged_; }
  double heading_rad() const noexcept { return heading_rad_; }
  const VirtualWallController& controller() const noexcept { return controller_; }
  const MasterWalls& walls() const noexcept { return walls_; }
  const CobotSteeringDrive& steering() const noexcept { return *steering_; }
  const CobotSensorNode& sensors() const noexcept { return *sensors_; }

 private:
  void Build(transport::CanPort& drive_port, transport::CanPort& sensor_port, transport::CanPort& force_port);
  void SendCycle(double steering_torque_Nm, bool brake) noexcept;

  CobotBackendConfig config_;
  fieldbus::Timebase timebase_;
  Capabilities capabilities_;
  std::string name_ = "cobot";
  std::unique_ptr<transport::CanPort> owned_drive_port_;
  std::unique_ptr<transport::CanPort> owned_sensor_port_;
  std::unique_ptr<transport::CanPort> owned_force_port_;
  std::unique_ptr<CobotSteeringDrive> steering_;
  std::unique_ptr<CobotSensorNode> sensors_;
  std::unique_ptr<fieldbus::CanForceSensor> force_;
  SensorFault force_fault_ = SensorFault::kNone;  ///< Latched: stale (kLost) or invalid force readings.
  Vec2 force_N_ = Vec2::Zero();
  VirtualWallController controller_;
  MasterWalls walls_;
  RateEstimator speed_estimator_;
  RateEstimator rate_estimator_;
  WallControllerInput input_{};
  Vec2 position_m_ = Vec2::Zero();
  double heading_rad_ = 0.0;
  double travel_m_ = 0.0;
  double period_s_ = 1e-3;
  bool active_ = false;
  bool safe_ = false;
  std::uint32_t pending_faults_ = kFaultNone;  ///< A bad Command, reported by the next Read.
  bool brake_engaged_ = false;
  bool stability_warning_ = false;  ///< StabilityStatus::warning of the last controller step.
  // The first faults since Activate, latched by Read() for FaultText on another thread (the event log).
  std::atomic<SteeringFault> first_steering_fault_{SteeringFault::kNone};
  std::atomic<SensorFault> first_sensor_fault_{SensorFault::kNone};
};

}  // namespace teleop::device::cobot
