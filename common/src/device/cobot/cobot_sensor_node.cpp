#include "device/cobot/cobot_sensor_node.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "teleop/error.hpp"
#include "teleop/fieldbus/canopen_frames.hpp"

namespace teleop::device::cobot {

using proto::can::CanFrame;

namespace {

std::int32_t I32(const CanFrame& f, std::size_t at) noexcept {
  const auto b = [&](std::size_t i) { return static_cast<std::uint32_t>(f.data[at + i]); };
  return static_cast<std::int32_t>(b(0) | (b(1) << 8) | (b(2) << 16) | (b(3) << 24));
}
void PutI32(CanFrame& f, std::size_t at, std::int32_t v) noexcept {
  const auto u = static_cast<std::uint32_t>(v);
  for (std::size_t i = 0; i < 4; ++i) f.data[at + i] = static_cast<std::uint8_t>(u >> (8 * i));
}
double MetresPerCount(const CobotSensorNodeConfig& c) noexcept {
  return 2.0 * std::numbers::pi * c.wheel_radius_m / c.wheel_counts_per_rev;
}

}  // namespace

fieldbus::CanForceSensorConfig CobotSensorNodeConfig::ForceSensorConfig() const noexcept {
  fieldbus::CanForceSensorConfig f;
  f.cob_id = ForceCobId();
  f.axes = 2;
  f.encoding = fieldbus::ForceSensorEncoding::kInt16;
  f.scale_N_per_count = force_N_per_unit;
  f.stale_after_ms = stale_after_ms;
  return f;
}

void Validate(const CobotSensorNodeConfig& c) {
  const auto fail = [](const std::string& what) { throw Error("cobot sensor node: " + what); };
  if (c.node_id < 1 || c.node_id > 127) fail("node_id must be 1..127");
  for (const std::uint32_t id : {c.WheelCobId(), c.ForceCobId(), c.BrakeCobId()}) {
    if (id > 0x7FF) fail("COB-IDs must be 11-bit (<= 0x7FF), got " + std::to_string(id));
  }
  if (c.WheelCobId() == c.ForceCobId()) fail("the wheel and force TPDOs need different COB-IDs");
  if (c.wheel_counts_per_rev < 1) fail("wheel_counts_per_rev must be >= 1");
  if (!(c.wheel_radius_m > 0.0) || !std::isfinite(c.wheel_radius_m)) fail("wheel_radius_m must be > 0");
  if (c.wheel_sign != 1.0 && c.wheel_sign != -1.0) fail("wheel_sign must be 1 or -1");
  if (!(c.force_N_per_unit > 0.0) || !std::isfinite(c.force_N_per_unit)) fail("force_N_per_unit must be > 0");
  if (!(c.stale_after_ms > 0.0) || !std::isfinite(c.stale_after_ms)) fail("stale_after_ms must be > 0");
  if (!(c.max_wheel_step_m > 0.0) || !std::isfinite(c.max_wheel_step_m)) fail("max_wheel_step_m must be > 0");
}

const char* ToString(SensorFault fault) noexcept {
  switch (fault) {
    case SensorFault::kNone:
      return "none";
    case SensorFault::kLost:
      return "sensor node lost";
    case SensorFault::kWheelJump:
      return "wheel encoder jump";
    case SensorFault::kBadFrame:
      return "malformed sensor frame";
    case SensorFault::kBusError:
      return "CAN error frame";
    case SensorFault::kForceInvalid:
      return "handle force sensor: no valid measurement";
  }
  return "?";
}

// ---------------------------------------------------------------- client

CobotSensorNode::CobotSensorNode(const CobotSensorNodeConfig& config, transport::CanPort& port,
                                 fieldbus::Timebase timebase)
    : config_(config), port_(port), timebase_(std::move(timebase)) {
  Validate(config_);
}

transport::CanReceiveOptions CobotSensorNode::ReceiveOptions(const CobotSensorNodeConfig& config) {
  transport::CanReceiveOptions o;
  o.filters = {transport::CanFilter::Exact(config.WheelCobId())};
  return o;
}

void CobotSensorNode::Latch(SensorFault fault) noexcept {
  if (fault_ == SensorFault::kNone) fault_ = fault;
}

void CobotSensorNode::Reset() noexcept {
  fault_ = SensorFault::kNone;
  wheel_seen_ = false;
  travel_m_ = 0.0;
}

SensorFault CobotSensorNode::Read(SensorSample& out) noexcept {
  const std::uint64_t now = timebase_.now_ns();
  bool fresh = false;
  CanFrame f{};
  while (port_.Read(f)) {
    if (f.error) {
      ++counters_.error_frames;
      continue;  // counted; a bus-off shows as the node going silent
    }
    if (f.extended || f.remote) continue;
    if (f.id == config_.WheelCobId()) {
      if (f.len != 4) {
        ++counters_.rejected_frames;
        Latch(SensorFault::kBadFrame);
        continue;
      }
      ++counters_.wheel_frames;
      const std::int32_t count = I32(f, 0);
      if (wheel_seen_) {
        // INTEGER32 arithmetic modulo 2^32: a wrapping counter gives the right step.
        const auto step =
            static_cast<std::int32_t>(static_cast<std::uint32_t>(count) - static_cast<std::uint32_t>(last_count_));
        const double step_m = config_.wheel_sign * step * MetresPerCount(config_);
        if (std::abs(step_m) > config_.max_wheel_step_m) {
          Latch(SensorFault::kWheelJump);
        } else if (fault_ == SensorFault::kNone) {
          travel_m_ += step_m;
        }
      }
      last_count_ = count;
      wheel_seen_ = true;
      last_frame_ns_ = now;
      fresh = true;
    }
  }
  const bool started = wheel_seen_;
  if (started && now > last_frame_ns_ && static_cast<double>(now - last_frame_ns_) > config_.stale_after_ms * 1e6) {
    Latch(SensorFault::kLost);
  }
  out.wheel_travel_m = travel_m_;
  out.fresh = fresh;
  out.started = started;
  out.fault = fault_;
  return fault_;
}

bool CobotSensorNode::WriteBrake(bool engaged) noexcept {
  if (!config_.has_brake) return true;
  CanFrame f{};
  f.id = config_.BrakeCobId();
  f.len = 1;
  f.data[0] = engaged ? 1 : 0;
  ++counters_.brake_writes;
  if (port_.Write(f) != transport::CanWriteStatus::kOk) {
    ++counters_.write_failures;
    return false;
  }
  return true;
}

// ---------------------------------------------------------------- simulated node

SimulatedCobotSensorNode::SimulatedCobotSensorNode(const CobotSensorNodeConfig& config, transport::CanPort& port)
    : config_(config), port_(port) {
  Validate(config_);
}

transport::CanReceiveOptions SimulatedCobotSensorNode::ReceiveOptions(const CobotSensorNodeConfig& config) {
  transport::CanReceiveOptions o;
  o.filters = {transport::CanFilter::Exact(fieldbus::canopen::cob::kSync),
               transport::CanFilter::Exact(config.BrakeCobId())};
  return o;
}

void SimulatedCobotSensorNode::Set(double wheel_travel_m, const Vec2& handle_force_N) noexcept {
  const double counts = std::round(config_.wheel_sign * wheel_travel_m / MetresPerCount(config_));
  counts_ = static_cast<std::int32_t>(static_cast<std::int64_t>(counts));  // wraps like the encoder
  fx_N_ = handle_force_N.x();                                              // NaN is sent as the sensor's invalid value
  fy_N_ = handle_force_N.y();
}

void SimulatedCobotSensorNode::Step() noexcept {
  CanFrame in{};
  while (port_.Read(in)) {
    if (in.error || in.extended) continue;
    if (in.id == config_.BrakeCobId() && config_.has_brake && in.len >= 1) {
      brake_ = (in.data[0] & 1u) != 0;
    } else if (in.id == fieldbus::canopen::cob::kSync && !silent_) {
      CanFrame wheel{};
      wheel.id = config_.WheelCobId();
      wheel.len = 4;
      PutI32(
          wheel, 0,
          static_cast<std::int32_t>(static_cast<std::uint32_t>(counts_) + static_cast<std::uint32_t>(count_offset_)));
      (void)port_.Write(wheel);
      CanFrame force{};
      const std::array<double, 2> f{fx_N_, fy_N_};
      if (fieldbus::EncodeForceFrame(config_.ForceSensorConfig(), f, force)) (void)port_.Write(force);
    }
  }
}

}  // namespace teleop::device::cobot
