#include "teleop/proto/can/mit_motor.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

#include "teleop/proto/can/bus_load.hpp"

namespace teleop::proto::can::mit {

namespace {

constexpr std::size_t kFrameBytes = 8;

bool RangesValid(const MotorRanges& r) noexcept {
  const auto positive = [](double x) { return std::isfinite(x) && x > 0; };
  return positive(r.position_max_rad) && positive(r.velocity_max_rad_per_s) && positive(r.torque_max_Nm) &&
         positive(r.kp_max_Nm_per_rad) && positive(r.kd_max_Nm_s_per_rad);
}

// Clamps x into [lo, hi], setting `bit` in `clamped` when it had to.
double Clamp(double x, double lo, double hi, std::uint8_t bit, std::uint8_t& clamped) noexcept {
  if (x < lo || x > hi) clamped = static_cast<std::uint8_t>(clamped | bit);
  return std::clamp(x, lo, hi);
}

void StartFrame(std::uint32_t id, CanFrame& out, bool fd) noexcept {
  out = CanFrame{};
  out.id = id & kMaxStandardId;
  out.fd = fd;
  out.brs = fd;
  out.len = kFrameBytes;
}

bool IsMitDataFrame(const CanFrame& frame) noexcept {
  return !frame.error && !frame.remote && !frame.extended && frame.len == kFrameBytes;
}

}  // namespace

std::uint32_t ToFixed(double x, double lo, double hi, int bits) noexcept {
  const double top = static_cast<double>((1U << bits) - 1U);
  const double scaled = (std::clamp(x, lo, hi) - lo) * top / (hi - lo);
  return static_cast<std::uint32_t>(std::clamp(scaled, 0.0, top));  // truncates, as float_to_uint does
}

double FromFixed(std::uint32_t v, double lo, double hi, int bits) noexcept {
  const double top = static_cast<double>((1U << bits) - 1U);
  return static_cast<double>(v) * (hi - lo) / top + lo;
}

EncodeResult EncodeCommand(const Command& command, const MotorRanges& ranges, std::uint32_t esc_id, CanFrame& out,
                           bool fd) noexcept {
  EncodeResult result;
  if (!RangesValid(ranges) || !std::isfinite(command.position_rad) || !std::isfinite(command.velocity_rad_per_s) ||
      !std::isfinite(command.kp_Nm_per_rad) || !std::isfinite(command.kd_Nm_s_per_rad) ||
      !std::isfinite(command.torque_Nm)) {
    return result;
  }
  const MotorRanges& r = ranges;
  std::uint8_t clamped = 0;
  const double p = Clamp(command.position_rad, -r.position_max_rad, r.position_max_rad, kFieldPosition, clamped);
  const double v =
      Clamp(command.velocity_rad_per_s, -r.velocity_max_rad_per_s, r.velocity_max_rad_per_s, kFieldVelocity, clamped);
  const double kp = Clamp(command.kp_Nm_per_rad, 0.0, r.kp_max_Nm_per_rad, kFieldKp, clamped);
  const double kd = Clamp(command.kd_Nm_s_per_rad, 0.0, r.kd_max_Nm_s_per_rad, kFieldKd, clamped);
  const double t = Clamp(command.torque_Nm, -r.torque_max_Nm, r.torque_max_Nm, kFieldTorque, clamped);

  const std::uint32_t p_int = ToFixed(p, -r.position_max_rad, r.position_max_rad, kPositionBits);
  const std::uint32_t v_int = ToFixed(v, -r.velocity_max_rad_per_s, r.velocity_max_rad_per_s, kVelocityBits);
  const std::uint32_t kp_int = ToFixed(kp, 0.0, r.kp_max_Nm_per_rad, kGainBits);
  const std::uint32_t kd_int = ToFixed(kd, 0.0, r.kd_max_Nm_s_per_rad, kGainBits);
  std::uint32_t t_int = ToFixed(t, -r.torque_max_Nm, r.torque_max_Nm, kTorqueBits);

  StartFrame(esc_id, out, fd);
  auto& d = out.data;
  d[0] = static_cast<std::uint8_t>(p_int >> 8);
  d[1] = static_cast<std::uint8_t>(p_int & 0xFF);
  d[2] = static_cast<std::uint8_t>(v_int >> 4);
  d[3] = static_cast<std::uint8_t>(((v_int & 0xF) << 4) | (kp_int >> 8));
  d[4] = static_cast<std::uint8_t>(kp_int & 0xFF);
  d[5] = static_cast<std::uint8_t>(kd_int >> 4);
  d[6] = static_cast<std::uint8_t>(((kd_int & 0xF) << 4) | (t_int >> 8));
  d[7] = static_cast<std::uint8_t>(t_int & 0xFF);
  // All fields at their top spell FF..FF Fx: FB..FE would be read by the motor as clear error, enable, disable or
  // set zero. Move the torque down to ...FA (at most 4 steps of 2·T_MAX/4095 below T_MAX).
  if (DecodeSpecial(out).has_value()) {
    t_int = (t_int & ~0xFFU) | 0xFAU;
    d[7] = static_cast<std::uint8_t>(t_int & 0xFF);
    result.nudged = true;
  }
  result.ok = true;
  result.clamped = clamped;
  return result;
}

bool DecodeCommand(const CanFrame& frame, const MotorRanges& ranges, Command& out) noexcept {
  if (!IsMitDataFrame(frame) || DecodeSpecial(frame).has_value() || !RangesValid(ranges)) return false;
  const auto& d = frame.data;
  const MotorRanges& r = ranges;
  const std::uint32_t p_int = (static_cast<std::uint32_t>(d[0]) << 8) | d[1];
  const std::uint32_t v_int = (static_cast<std::uint32_t>(d[2]) << 4) | (d[3] >> 4);
  const std::uint32_t kp_int = ((static_cast<std::uint32_t>(d[3]) & 0xFU) << 8) | d[4];
  const std::uint32_t kd_int = (static_cast<std::uint32_t>(d[5]) << 4) | (d[6] >> 4);
  const std::uint32_t t_int = ((static_cast<std::uint32_t>(d[6]) & 0xFU) << 8) | d[7];
  out.position_rad = FromFixed(p_int, -r.position_max_rad, r.position_max_rad, kPositionBits);
  out.velocity_rad_per_s = FromFixed(v_int, -r.velocity_max_rad_per_s, r.velocity_max_rad_per_s, kVelocityBits);
  out.kp_Nm_per_rad = FromFixed(kp_int, 0.0, r.kp_max_Nm_per_rad, kGainBits);
  out.kd_Nm_s_per_rad = FromFixed(kd_int, 0.0, r.kd_max_Nm_s_per_rad, kGainBits);
  out.torque_Nm = FromFixed(t_int, -r.torque_max_Nm, r.torque_max_Nm, kTorqueBits);
  return true;
}

bool IsFault(std::uint8_t status_code) noexcept {
  return status_code != static_cast<std::uint8_t>(MotorStatus::kDisabled) &&
         status_code != static_cast<std::uint8_t>(MotorStatus::kEnabled);
}

std::string_view StatusName(std::uint8_t status_code) noexcept {
  switch (static_cast<MotorStatus>(status_code)) {
    case MotorStatus::kDisabled:
      return "disabled";
    case MotorStatus::kEnabled:
      return "enabled";
    case MotorStatus::kOverVoltage:
      return "over-voltage";
    case MotorStatus::kUnderVoltage:
      return "under-voltage";
    case MotorStatus::kOverCurrent:
      return "over-current";
    case MotorStatus::kMosOverTemperature:
      return "MOS over-temperature";
    case MotorStatus::kCoilOverTemperature:
      return "coil over-temperature";
    case MotorStatus::kCommunicationLost:
      return "communication lost";
    case MotorStatus::kOverload:
      return "overload";
  }
  return "unknown error code";
}

DecodeStatus DecodeFeedback(const CanFrame& frame, const MotorRanges& ranges, std::uint32_t master_id,
                            std::uint32_t esc_id, Feedback& out) noexcept {
  if (frame.error || frame.remote || frame.extended || frame.id != master_id) return DecodeStatus::kWrongId;
  if (!IsMitDataFrame(frame)) return DecodeStatus::kWrongLength;
  const auto& d = frame.data;
  if ((d[0] & 0x0FU) != (esc_id & 0x0FU)) return DecodeStatus::kWrongMotor;
  const MotorRanges& r = ranges;
  const std::uint32_t p_int = (static_cast<std::uint32_t>(d[1]) << 8) | d[2];
  const std::uint32_t v_int = (static_cast<std::uint32_t>(d[3]) << 4) | (d[4] >> 4);
  const std::uint32_t t_int = ((static_cast<std::uint32_t>(d[4]) & 0xFU) << 8) | d[5];
  Feedback f;
  f.esc_id_low = static_cast<std::uint8_t>(d[0] & 0x0FU);
  f.status = static_cast<std::uint8_t>(d[0] >> 4);
  f.position_rad = FromFixed(p_int, -r.position_max_rad, r.position_max_rad, kPositionBits);
  f.velocity_rad_per_s = FromFixed(v_int, -r.velocity_max_rad_per_s, r.velocity_max_rad_per_s, kVelocityBits);
  f.torque_Nm = FromFixed(t_int, -r.torque_max_Nm, r.torque_max_Nm, kTorqueBits);
  f.mos_temperature_C = d[6];
  f.rotor_temperature_C = d[7];
  out = f;
  return DecodeStatus::kOk;
}

void EncodeSpecial(Special what, std::uint32_t esc_id, CanFrame& out, bool fd) noexcept {
  StartFrame(esc_id, out, fd);
  for (std::size_t i = 0; i + 1 < kFrameBytes; ++i) out.data[i] = 0xFF;
  out.data[kFrameBytes - 1] = static_cast<std::uint8_t>(what);
}

std::optional<Special> DecodeSpecial(const CanFrame& frame) noexcept {
  if (!IsMitDataFrame(frame)) return std::nullopt;
  for (std::size_t i = 0; i + 1 < kFrameBytes; ++i) {
    if (frame.data[i] != 0xFF) return std::nullopt;
  }
  const std::uint8_t last = frame.data[kFrameBytes - 1];
  if (last < static_cast<std::uint8_t>(Special::kClearError) || last > static_cast<std::uint8_t>(Special::kSetZero)) {
    return std::nullopt;
  }
  return static_cast<Special>(last);
}

bool IsFloatRegister(std::uint8_t reg) noexcept {
  return reg == static_cast<std::uint8_t>(Register::kPositionMax) ||
         reg == static_cast<std::uint8_t>(Register::kVelocityMax) ||
         reg == static_cast<std::uint8_t>(Register::kTorqueMax);
}

float Parameter::FloatValue() const noexcept { return std::bit_cast<float>(value); }
std::uint32_t Parameter::FromFloat(float v) noexcept { return std::bit_cast<std::uint32_t>(v); }

void EncodeParameter(const Parameter& request, CanFrame& out) noexcept {
  StartFrame(kParameterId, out, false);
  auto& d = out.data;
  d[0] = static_cast<std::uint8_t>(request.esc_id & 0xFF);
  d[1] = static_cast<std::uint8_t>(request.esc_id >> 8);
  d[2] = static_cast<std::uint8_t>(request.op);
  const bool save = request.op == ParameterOp::kSave;
  d[3] = save ? std::uint8_t{1} : request.reg;
  const std::uint32_t v = request.op == ParameterOp::kWrite ? request.value : 0U;
  for (std::size_t i = 0; i < 4; ++i) d[4 + i] = static_cast<std::uint8_t>(v >> (8 * i));
}

std::optional<Parameter> DecodeParameter(const CanFrame& frame) noexcept {
  if (!IsMitDataFrame(frame)) return std::nullopt;
  const auto& d = frame.data;
  const auto op = static_cast<ParameterOp>(d[2]);
  if (op != ParameterOp::kRead && op != ParameterOp::kWrite && op != ParameterOp::kSave) return std::nullopt;
  Parameter p;
  p.esc_id = static_cast<std::uint16_t>(d[0] | (static_cast<std::uint16_t>(d[1]) << 8));
  p.op = op;
  p.reg = d[3];
  for (std::size_t i = 0; i < 4; ++i) p.value |= static_cast<std::uint32_t>(d[4 + i]) << (8 * i);
  return p;
}

MitBusLoad ComputeMitBusLoad(int motors, double rate_hz, bool fd, bool brs, double nominal_bit_per_s,
                             double data_bit_per_s, double max_load) noexcept {
  MitBusLoad b;
  const CanBitrates rates{nominal_bit_per_s, data_bit_per_s};
  if (!(rate_hz > 0) || !(nominal_bit_per_s > 0) || !(data_bit_per_s > 0)) return b;
  b.exchange_time_s = 2.0 * FrameTime_s(fd, fd && brs, false, kFrameBytes, rates);
  b.load = std::max(motors, 0) * b.exchange_time_s * rate_hz;
  b.max_motors = static_cast<int>(std::floor(max_load / (b.exchange_time_s * rate_hz) + 1e-9));
  return b;
}

}  // namespace teleop::proto::can::mit
