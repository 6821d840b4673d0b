#pragma once

// The cobot's wheel encoder and handle force sensor on a separate CAN node (docs/cobot.md, "The fieldbus
// rig"), and the wheel brake output where the rig has one. The node speaks CANopen process data
// (CiA 301 synchronous PDOs, sent after each SYNC of the steering drive's client):
//  - wheel TPDO (default COB-ID 0x180 + node, 4 bytes): the wheel encoder's position value, INTEGER32 little-endian
//    (CiA 406 object 0x6004), counts; it may wrap;
//  - force TPDO (default 0x280 + node, 4 bytes): F_x, F_y as INTEGER16 little-endian (CiA 401 analog inputs 0x6401
//    sub 1 and 2), force_N_per_unit N per unit, world frame; 0x8000 is "no valid measurement". The host reads it
//    with the generic teleop::fieldbus::CanForceSensor (ForceSensorConfig()), on a port of its own;
//  - brake RPDO (default 0x200 + node, 1 byte, only with has_brake): bit 0 of CiA 401 digital outputs 0x6200 sub 1,
//    1 = wheel brake engaged.
// The node's own set-up (its PDO mapping, NMT start) is the rig's commissioning, not done here.

#include <cstdint>
#include <memory>

#include "device/cobot/planar.hpp"
#include "teleop/fieldbus/can_force_sensor.hpp"
#include "teleop/fieldbus/canopen_timebase.hpp"
#include "teleop/transport/can_filter.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::device::cobot {

struct CobotSensorNodeConfig {
  std::uint8_t node_id = 10;       ///< 1..127.
  std::uint32_t wheel_cob_id = 0;  ///< 0: 0x180 + node_id.
  std::uint32_t force_cob_id = 0;  ///< 0: 0x280 + node_id.
  std::uint32_t brake_cob_id = 0;  ///< 0: 0x200 + node_id.
  bool has_brake = false;          ///< The node drives the wheel brake.
  int wheel_counts_per_rev = 16384;
  double wheel_radius_m = 0.05;
  double wheel_sign = 1.0;         ///< -1 when the encoder counts down as the cart rolls forward.
  double force_N_per_unit = 0.01;  ///< Scaling of the analog inputs.
  double stale_after_ms = 10.0;    ///< No frame of either kind for this long: the node is lost.
  /// A wheel travel step larger than this between two frames is an encoder jump (a counting error or a broken
  /// cable): at 1 kHz, 10 mm is 10 m/s.
  double max_wheel_step_m = 0.01;

  std::uint32_t WheelCobId() const noexcept { return wheel_cob_id != 0 ? wheel_cob_id : 0x180u + node_id; }
  std::uint32_t ForceCobId() const noexcept { return force_cob_id != 0 ? force_cob_id : 0x280u + node_id; }
  std::uint32_t BrakeCobId() const noexcept { return brake_cob_id != 0 ? brake_cob_id : 0x200u + node_id; }
  /// The force TPDO as the generic force-sensor client reads it (2 axes, INTEGER16).
  fieldbus::CanForceSensorConfig ForceSensorConfig() const noexcept;
};
/// teleop::Error naming the field.
void Validate(const CobotSensorNodeConfig& config);

enum class SensorFault : std::uint8_t { kNone, kLost, kWheelJump, kBadFrame, kBusError, kForceInvalid };
const char* ToString(SensorFault fault) noexcept;

struct SensorSample {
  double wheel_travel_m = 0.0;  ///< Since the first frame (signed, wheel_sign applied).
  Vec2 handle_force_N = Vec2::Zero();
  bool fresh = false;                      ///< A new frame since the last Read.
  bool started = false;                    ///< Both kinds of frame have arrived at least once.
  SensorFault fault = SensorFault::kNone;  ///< Latched until Reset().
};

struct SensorNodeCounters {
  std::uint64_t wheel_frames = 0;
  std::uint64_t rejected_frames = 0;  ///< Wrong length.
  std::uint64_t error_frames = 0;
  std::uint64_t brake_writes = 0;
  std::uint64_t write_failures = 0;
};

/// The host's client of the sensor node's wheel TPDO and brake RPDO. Read/WriteBrake run in the control cycle:
/// non-blocking, no allocation. A fault (lost node, wheel jump, malformed frame, error frame) latches until Reset();
/// the travel then keeps its last trusted value.
class CobotSensorNode {
 public:
  /// Validates (throws teleop::Error); `port` must outlive the client and receive ReceiveOptions(config).
  CobotSensorNode(const CobotSensorNodeConfig& config, transport::CanPort& port,
                  fieldbus::Timebase timebase = fieldbus::Timebase::Steady());
  static transport::CanReceiveOptions ReceiveOptions(const CobotSensorNodeConfig& config);

  [[nodiscard]] SensorFault Read(SensorSample& out) noexcept;
  /// Sends the brake RPDO (has_brake only; false when the port refused it).
  bool WriteBrake(bool engaged) noexcept;
  /// Clears the latch and waits for both frames again (set-up).
  void Reset() noexcept;

  SensorFault fault() const noexcept { return fault_; }
  const SensorNodeCounters& counters() const noexcept { return counters_; }
  const CobotSensorNodeConfig& config() const noexcept { return config_; }

 private:
  void Latch(SensorFault fault) noexcept;

  CobotSensorNodeConfig config_;
  transport::CanPort& port_;
  fieldbus::Timebase timebase_;
  SensorFault fault_ = SensorFault::kNone;
  bool wheel_seen_ = false;
  std::int32_t last_count_ = 0;
  double travel_m_ = 0.0;
  std::uint64_t last_frame_ns_ = 0;
  SensorNodeCounters counters_{};
};

/// A simulated sensor node on a CAN port (tests, the emulated bus): after each SYNC it sends the wheel and force
/// TPDOs of the values last Set(), and it keeps the brake output the host wrote. Fault injection for tests.
class SimulatedCobotSensorNode {
 public:
  SimulatedCobotSensorNode(const CobotSensorNodeConfig& config, transport::CanPort& port);
  /// SYNC and the brake RPDO.
  static transport::CanReceiveOptions ReceiveOptions(const CobotSensorNodeConfig& config);

  /// The rig's state the next TPDOs carry: wheel travel (m) and the operator's force (N, world).
  void Set(double wheel_travel_m, const Vec2& handle_force_N) noexcept;
  /// Reads pending frames: answers each SYNC, applies brake RPDOs.
  void Step() noexcept;
  bool brake_engaged() const noexcept { return brake_; }
  void SetSilent(bool silent) noexcept { silent_ = silent; }
  /// Adds `counts` to every wheel count sent from now on (a counting error).
  void JumpWheelCounts(std::int32_t counts) noexcept { count_offset_ += counts; }

 private:
  CobotSensorNodeConfig config_;
  transport::CanPort& port_;
  std::int32_t counts_ = 0;
  std::int32_t count_offset_ = 0;
  double fx_N_ = 0.0;
  double fy_N_ = 0.0;
  bool brake_ = false;
  bool silent_ = false;
};

}  // namespace teleop::device::cobot
