#include "teleop/fieldbus/can_force_sensor.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "teleop/error.hpp"

namespace teleop::fieldbus {
namespace {

/// Byte `b` of axis `a` in a frame of `bytes`-byte axes.
std::size_t ByteIndex(int a, int bytes, int b) noexcept {
  return static_cast<std::size_t>(a) * static_cast<std::size_t>(bytes) + static_cast<std::size_t>(b);
}

int AxisBytes(ForceSensorEncoding e) noexcept { return e == ForceSensorEncoding::kInt16 ? 2 : 4; }

std::int64_t InvalidRaw(ForceSensorEncoding e) noexcept {
  return e == ForceSensorEncoding::kInt16 ? std::numeric_limits<std::int16_t>::min()
                                          : std::numeric_limits<std::int32_t>::min();
}

std::int64_t MaxRaw(ForceSensorEncoding e) noexcept {
  return e == ForceSensorEncoding::kInt16 ? std::numeric_limits<std::int16_t>::max()
                                          : std::numeric_limits<std::int32_t>::max();
}

}  // namespace

const char* ToString(ForceSensorEncoding encoding) noexcept {
  return encoding == ForceSensorEncoding::kInt16 ? "int16" : "int32";
}

const char* ToString(CanForceSensorStatus status) noexcept {
  switch (status) {
    case CanForceSensorStatus::kOk:
      return "ok";
    case CanForceSensorStatus::kNoNewData:
      return "no new data";
    case CanForceSensorStatus::kStale:
      return "stale";
    case CanForceSensorStatus::kBusOff:
      return "bus-off";
  }
  return "?";
}

void CanForceSensorConfig::Validate(const char* what) const {
  const std::string w(what);
  if (cob_id == 0 || cob_id > 0x7FFu) throw Error(w + ": cob_id must be an 11-bit identifier 0x001..0x7FF");
  if (cob_id == canopen::cob::kSync) throw Error(w + ": cob_id 0x080 is the SYNC");
  const int max_axes = encoding == ForceSensorEncoding::kInt16 ? 4 : 2;
  if (axes < 1 || axes > max_axes) {
    throw Error(w + ": axes must be 1.." + std::to_string(max_axes) + " for " + ToString(encoding) +
                " (one classic frame)");
  }
  if (!std::isfinite(scale_N_per_count) || scale_N_per_count == 0.0) {
    throw Error(w + ": scale_N_per_count must be finite and non-zero");
  }
  for (const double o : offset_N) {
    if (!std::isfinite(o)) throw Error(w + ": offset_N must be finite");
  }
  if (!(stale_after_ms > 0.0) || !std::isfinite(stale_after_ms)) throw Error(w + ": stale_after_ms must be > 0");
}

bool EncodeForceFrame(const CanForceSensorConfig& config, std::span<const double> force_N, canopen::CanFrame& frame,
                      int* clamped) noexcept {
  if (force_N.size() < static_cast<std::size_t>(config.axes)) return false;
  frame = canopen::CanFrame{};
  frame.id = config.cob_id;
  frame.len = static_cast<std::uint8_t>(config.FrameBytes());
  const int bytes = AxisBytes(config.encoding);
  const std::int64_t max = MaxRaw(config.encoding);
  int n_clamped = 0;
  for (int a = 0; a < config.axes; ++a) {
    const double si = force_N[static_cast<std::size_t>(a)];
    std::int64_t raw = InvalidRaw(config.encoding);
    if (std::isfinite(si)) {
      const double counts = std::round((si - config.offset_N[static_cast<std::size_t>(a)]) / config.scale_N_per_count);
      if (counts > static_cast<double>(max) || counts < static_cast<double>(-max)) {
        ++n_clamped;
        raw = counts > 0.0 ? max : -max;
      } else {
        raw = static_cast<std::int64_t>(counts);
      }
    }
    const auto u = static_cast<std::uint32_t>(raw);
    for (int b = 0; b < bytes; ++b) {
      frame.data[ByteIndex(a, bytes, b)] = static_cast<std::uint8_t>(u >> (8 * b));
    }
  }
  if (clamped != nullptr) *clamped = n_clamped;
  return true;
}

bool DecodeForceFrame(const CanForceSensorConfig& config, const canopen::CanFrame& frame,
                      std::span<double> force_N) noexcept {
  if (frame.error || frame.fd || frame.extended || frame.remote || frame.id != config.cob_id ||
      frame.len != config.FrameBytes() || force_N.size() < static_cast<std::size_t>(config.axes)) {
    return false;
  }
  const int bytes = AxisBytes(config.encoding);
  for (int a = 0; a < config.axes; ++a) {
    std::uint32_t u = 0;
    for (int b = 0; b < bytes; ++b) {
      u |= std::uint32_t{frame.data[ByteIndex(a, bytes, b)]} << (8 * b);
    }
    const std::int64_t raw = bytes == 2 ? std::int64_t{static_cast<std::int16_t>(static_cast<std::uint16_t>(u))}
                                        : std::int64_t{static_cast<std::int32_t>(u)};
    force_N[static_cast<std::size_t>(a)] =
        raw == InvalidRaw(config.encoding)
            ? std::numeric_limits<double>::quiet_NaN()
            : static_cast<double>(raw) * config.scale_N_per_count + config.offset_N[static_cast<std::size_t>(a)];
  }
  return true;
}

CanForceSensor::CanForceSensor(const CanForceSensorConfig& config, transport::CanPort& port, Timebase timebase)
    : config_(config), port_(port), timebase_(std::move(timebase)) {
  config_.Validate();
}

transport::CanReceiveOptions CanForceSensor::ReceiveOptions(const CanForceSensorConfig& config) {
  transport::CanReceiveOptions o;
  o.filters = {transport::CanFilter::Exact(config.cob_id)};
  return o;
}

CanForceSensorStatus CanForceSensor::Read(CanForceReading& out) noexcept {
  const std::uint64_t now = timebase_.now_ns();
  bool fresh = false;
  canopen::CanFrame frame;
  std::array<double, kMaxForceSensorAxes> values{};
  while (port_.Read(frame)) {
    if (frame.error) {
      ++counters_.error_frames;
      if ((frame.error_class & proto::can::kErrBusOff) != 0) {
        ++counters_.bus_off;
        bus_off_ = true;
      }
      if ((frame.error_class & proto::can::kErrRestarted) != 0) bus_off_ = false;
      continue;
    }
    if (frame.id != config_.cob_id || frame.extended) {
      ++counters_.other_frames;
      continue;
    }
    if (!DecodeForceFrame(config_, frame, values)) {
      ++counters_.rejected;
      continue;
    }
    for (int a = 0; a < config_.axes; ++a) {
      if (std::isnan(values[static_cast<std::size_t>(a)])) ++counters_.invalid_values;
    }
    ++counters_.frames;
    newest_.force_N = values;
    newest_.stamp_ns = now;
    seen_ = true;
    fresh = true;
  }
  out = newest_;
  out.fresh = fresh;
  if (bus_off_) return CanForceSensorStatus::kBusOff;
  if (!seen_ || static_cast<double>(now - newest_.stamp_ns) > config_.stale_after_ms * 1e6) {
    ++counters_.stale_reads;
    return CanForceSensorStatus::kStale;
  }
  return fresh ? CanForceSensorStatus::kOk : CanForceSensorStatus::kNoNewData;
}

}  // namespace teleop::fieldbus
