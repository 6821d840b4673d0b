#pragma once

// A force/torque sensor node on CAN (docs/cia402.md, "Force sensor node"): the sensor sends its axes in one classic
// data frame, TPDO-style (CiA 301 PDO layout: entries little-endian, one after the other, no header), on a COB-ID of
// the config, either on each SYNC (transmission type 1) or cyclically; the client needs neither, it keeps the newest
// frame. Generic: 1..4 axes of INTEGER16 or 1..2 of INTEGER32, one scale (N or N·m per count) and an offset per
// axis. The most negative raw value (0x8000 / 0x80000000) is the sensor's "no valid measurement" (overload, error):
// it reads as NaN, which a device reports as kFaultNonFiniteSensor. No data for stale_after_ms is a fault.
//
// Frame (2 axes, INTEGER16, scale 0.01 N): Fx = 12.34 N, Fy = -5 N → raw 1234, -500 → `190#D2040CFE`.

#include <array>
#include <cstdint>
#include <span>

#include "teleop/fieldbus/canopen_frames.hpp"
#include "teleop/fieldbus/canopen_timebase.hpp"
#include "teleop/transport/can_filter.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::fieldbus {

inline constexpr int kMaxForceSensorAxes = 4;

enum class ForceSensorEncoding : std::uint8_t {
  kInt16,  ///< INTEGER16 per axis (1..4 axes).
  kInt32,  ///< INTEGER32 per axis (1..2 axes).
};
const char* ToString(ForceSensorEncoding encoding) noexcept;

struct CanForceSensorConfig {
  std::uint32_t cob_id = 0x190;  ///< 11-bit identifier of the sensor's frame (a TPDO's: 0x181..0x57F recommended).
  int axes = 2;                  ///< Values in the frame, in order (F_x, F_y, ...).
  ForceSensorEncoding encoding = ForceSensorEncoding::kInt16;
  double scale_N_per_count = 0.01;                     ///< SI per raw count, non-zero (negative flips every axis).
  std::array<double, kMaxForceSensorAxes> offset_N{};  ///< SI value at raw 0, per axis (bias).
  double stale_after_ms = 10.0;                        ///< No frame for this long: kStale (a fault).

  /// Throws teleop::Error naming the field (`what` prefixes it: "device.hybrid.fieldbus.force_sensor").
  void Validate(const char* what = "force sensor") const;
  int FrameBytes() const noexcept { return axes * (encoding == ForceSensorEncoding::kInt16 ? 2 : 4); }
};

/// Pure codec. Encode: SI → raw (rounded, clamped to the type's range less its invalid value, counted by the return),
/// NaN → the invalid value. False when `force_N` has fewer than `axes` values. `clamped` counts clamped axes.
[[nodiscard]] bool EncodeForceFrame(const CanForceSensorConfig& config, std::span<const double> force_N,
                                    canopen::CanFrame& frame, int* clamped = nullptr) noexcept;
/// Decode: false (nothing written) when the frame is not a classic data frame of exactly FrameBytes() on cob_id;
/// the invalid raw value gives NaN.
[[nodiscard]] bool DecodeForceFrame(const CanForceSensorConfig& config, const canopen::CanFrame& frame,
                                    std::span<double> force_N) noexcept;

enum class CanForceSensorStatus : std::uint8_t {
  kOk = 0,
  kNoNewData,  ///< No frame since the last Read, not yet stale: the previous values.
  kStale,      ///< No frame for stale_after_ms, or none ever: a fault.
  kBusOff,     ///< The controller is bus-off.
};
const char* ToString(CanForceSensorStatus status) noexcept;

struct CanForceReading {
  std::array<double, kMaxForceSensorAxes> force_N{};  ///< SI, the first `axes` used; NaN: no valid measurement.
  std::uint64_t stamp_ns = 0;                         ///< When the newest frame was read (Timebase clock); 0: none.
  bool fresh = false;                                 ///< New since the last Read.
};

struct CanForceSensorCounters {
  std::uint64_t frames = 0;
  std::uint64_t rejected = 0;        ///< On cob_id but of the wrong length / kind (never misread).
  std::uint64_t invalid_values = 0;  ///< Axes that carried the invalid raw value.
  std::uint64_t stale_reads = 0;
  std::uint64_t error_frames = 0;
  std::uint64_t bus_off = 0;
  std::uint64_t other_frames = 0;
};

/// The client: Read() drains the port in the cycle (non-blocking, no allocation, no exceptions).
class CanForceSensor {
 public:
  /// Validates (throws teleop::Error). `port` must outlive the client and should receive ReceiveOptions(config).
  CanForceSensor(const CanForceSensorConfig& config, transport::CanPort& port, Timebase timebase = Timebase::Steady());

  /// The sensor's COB-ID and error frames.
  static transport::CanReceiveOptions ReceiveOptions(const CanForceSensorConfig& config);

  /// Cycle: drains the port, fills `out` with the newest values. kStale also before the first frame.
  [[nodiscard]] CanForceSensorStatus Read(CanForceReading& out) noexcept;

  const CanForceSensorConfig& config() const noexcept { return config_; }
  const CanForceSensorCounters& counters() const noexcept { return counters_; }

 private:
  CanForceSensorConfig config_;
  transport::CanPort& port_;
  Timebase timebase_;
  CanForceReading newest_{};
  bool seen_ = false;
  bool bus_off_ = false;
  CanForceSensorCounters counters_{};
};

}  // namespace teleop::fieldbus
