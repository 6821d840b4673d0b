#pragma once

#include "device/cobot/cobot_sensor_node.hpp"
#include "device/cobot/cobot_steering_drive.hpp"
#include "teleop/fieldbus/can_port_config.hpp"

namespace teleop::device::cobot {

/// The real unicycle cobot on CAN (`device.cobot.rig: fieldbus`, docs/cobot.md): the steering motor on a CiA 402
/// drive in cyclic synchronous torque mode (the steering angle from its position actual value), the wheel encoder,
/// the handle force sensor and the wheel brake (if any) on a separate CAN node. Both on one bus (`can`), each
/// client on its own port.
struct CobotFieldbusConfig {
  fieldbus::CanPortConfig can{};
  CobotSteeringDriveConfig steering{};
  /// The cart's heading (world, rad) when the steering angle reads 0; the drive's scaling.sign gives the direction.
  double steering_offset_rad = 0.0;
  CobotSensorNodeConfig sensors{};
  /// Activate: how long to wait for the first frames of the steering drive and the sensor node.
  double first_frames_timeout_ms = 500.0;
};

}  // namespace teleop::device::cobot
