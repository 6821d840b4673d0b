#pragma once

#include "device/cobot/planar.hpp"

namespace teleop::device::cobot {

/// The prototype's sensing (§3.2): a wheel encoder (translational speed u), a steering encoder (steering angle),
/// absolute position from the instrumented xy frame (linear potentiometers), and a handle force sensor (F_x, F_y).
/// A resolution of 0 means ideal (no quantization).
struct CobotSensorConfig {
  double wheel_radius_m = 0.05;
  int wheel_encoder_counts_per_rev = 16384;
  int steering_encoder_counts_per_rev = 16384;
  double position_resolution_m = 1e-5;
  double force_resolution_N = 0.01;
};

/// One sample of the sensors (what the controller sees).
struct CobotMeasurement {
  Vec2 position_m = Vec2::Zero();      ///< Absolute position of the wheel (m, world).
  double steering_angle_rad = 0.0;     ///< Heading of the wheel from the world x axis (the xy frame does not rotate).
  double wheel_angle_rad = 0.0;        ///< Wheel rotation; u = r·d(angle)/dt.
  Vec2 handle_force_N = Vec2::Zero();  ///< Operator force (N, world).
};

/// Throws teleop::Error naming the first bad field.
void Validate(const CobotSensorConfig& config);

/// Quantizes `value` to `step` (step ≤ 0: unchanged).
[[nodiscard]] double Quantize(double value, double step) noexcept;

/// The sensors' view of a true state (ideal geometry, quantized readings).
[[nodiscard]] CobotMeasurement Measure(const CobotSensorConfig& config, const Vec2& position_m, double heading_rad,
                                       double wheel_travel_m, const Vec2& handle_force_N) noexcept;

}  // namespace teleop::device::cobot
