#include "teleop/fieldbus/simulated_mit_motor.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

namespace teleop::fieldbus {

namespace mit = proto::can::mit;

namespace {
constexpr std::uint8_t Code(mit::MotorStatus s) noexcept { return static_cast<std::uint8_t>(s); }
constexpr std::uint8_t Reg(mit::Register r) noexcept { return static_cast<std::uint8_t>(r); }
}  // namespace

SimulatedMitMotor::SimulatedMitMotor(const SimulatedMitMotorConfig& config, transport::CanPort& port)
    : config_(config),
      port_(port),
      ranges_(config.ranges),
      esc_id_(config.esc_id),
      master_id_(config.master_id),
      timeout_counts_(config.timeout_counts) {}

transport::CanReceiveOptions SimulatedMitMotor::ReceiveOptions(const SimulatedMitMotorConfig& config) {
  transport::CanReceiveOptions o;
  o.filters = {transport::CanFilter::Exact(config.esc_id), transport::CanFilter::Exact(mit::kParameterId)};
  o.error_mask = 0;
  o.fd = true;
  return o;
}

void SimulatedMitMotor::InjectFault(mit::MotorStatus status) noexcept {
  injected_ = Code(status);
  status_ = injected_;
}

double SimulatedMitMotor::OutputTorque() noexcept {
  double tau = 0;
  if (enabled() && control_mode_ == mit::kControlModeMit) {
    tau = command_.kp_Nm_per_rad * (command_.position_rad - position_rad()) +
          command_.kd_Nm_s_per_rad * (command_.velocity_rad_per_s - omega_rad_per_s_) + command_.torque_Nm;
    tau = std::clamp(tau, -config_.peak_torque_Nm, config_.peak_torque_Nm);
  }
  torque_Nm_ = tau;
  return tau;
}

void SimulatedMitMotor::Integrate(double dt_s) noexcept {
  if (config_.external_shaft) return;  // the owner integrates the shaft and asks for OutputTorque
  const double h = config_.integration_step_s;
  remainder_s_ += dt_s;
  while (remainder_s_ >= h) {
    remainder_s_ -= h;
    const double tau = OutputTorque();
    const double drive = tau + load_torque_Nm_ - config_.viscous_Nms_per_rad * omega_rad_per_s_;
    // Stiction: at rest, or slow enough that friction takes the rest of the momentum within this step.
    const double margin_Nm = config_.coulomb_Nm - std::abs(drive);
    if (margin_Nm >= 0.0 && std::abs(omega_rad_per_s_) * config_.inertia_kg_m2 <= margin_Nm * h) {
      omega_rad_per_s_ = 0.0;
      continue;
    }
    const double friction = omega_rad_per_s_ != 0.0 ? std::copysign(config_.coulomb_Nm, omega_rad_per_s_)
                                                    : std::copysign(config_.coulomb_Nm, drive);
    const double next = omega_rad_per_s_ + (drive - friction) / config_.inertia_kg_m2 * h;
    // Coulomb friction stops the shaft; it never reverses it within one step.
    omega_rad_per_s_ = (omega_rad_per_s_ != 0.0 && next * omega_rad_per_s_ < 0.0) ? 0.0 : next;
    theta_rad_ += omega_rad_per_s_ * h;
  }
}

void SimulatedMitMotor::Step(std::int64_t now_ns) noexcept {
  if (last_ns_ < 0) {
    last_ns_ = now_ns;
    last_frame_ns_ = now_ns;
  }
  Integrate(static_cast<double>(now_ns - last_ns_) * 1e-9);
  last_ns_ = now_ns;
  proto::can::CanFrame frame;
  while (port_.Read(frame)) Serve(frame, now_ns);
  const double timeout_s = static_cast<double>(timeout_counts_) * mit::kTimeoutCount_s;
  if (enabled() && timeout_counts_ > 0 && static_cast<double>(now_ns - last_frame_ns_) * 1e-9 > timeout_s) {
    status_ = Code(mit::MotorStatus::kCommunicationLost);  // disabled: no torque until clear error and enable
  }
}

void SimulatedMitMotor::Serve(const proto::can::CanFrame& frame, std::int64_t now_ns) noexcept {
  if (frame.error || frame.remote || frame.extended) return;
  fd_seen_ = frame.fd;
  if (frame.id == mit::kParameterId) {
    const auto request = mit::DecodeParameter(frame);
    if (request && request->esc_id == esc_id_) {
      last_frame_ns_ = now_ns;
      ServeParameter(*request);
    }
    return;
  }
  if (frame.id != esc_id_ || frame.len != 8) return;
  last_frame_ns_ = now_ns;
  if (const auto special = mit::DecodeSpecial(frame)) {
    ServeSpecial(*special);
  } else {
    mit::Command c;
    if (mit::DecodeCommand(frame, ranges_, c)) {
      ++commands_received_;
      if (enabled()) command_ = c;
    }
  }
  SendFeedback();
}

void SimulatedMitMotor::ServeSpecial(mit::Special what) noexcept {
  switch (what) {
    case mit::Special::kEnable:
      if (!mit::IsFault(status_) && !ignore_enable_) {
        status_ = Code(mit::MotorStatus::kEnabled);
        command_ = mit::Command{};
      }
      break;
    case mit::Special::kDisable:
      if (!mit::IsFault(status_)) status_ = Code(mit::MotorStatus::kDisabled);
      break;
    case mit::Special::kSetZero:
      zero_offset_rad_ = theta_rad_;
      break;
    case mit::Special::kClearError:
      if (injected_ == 0 && mit::IsFault(status_)) status_ = Code(mit::MotorStatus::kDisabled);
      break;
  }
}

std::uint32_t SimulatedMitMotor::ReadRegister(std::uint8_t reg) const noexcept {
  switch (reg) {
    case Reg(mit::Register::kMasterId):
      return master_id_;
    case Reg(mit::Register::kEscId):
      return esc_id_;
    case Reg(mit::Register::kTimeout):
      return timeout_counts_;
    case Reg(mit::Register::kControlMode):
      return control_mode_;
    case Reg(mit::Register::kFirmware):
      return config_.firmware;
    case Reg(mit::Register::kPositionMax):
      return mit::Parameter::FromFloat(static_cast<float>(ranges_.position_max_rad));
    case Reg(mit::Register::kVelocityMax):
      return mit::Parameter::FromFloat(static_cast<float>(ranges_.velocity_max_rad_per_s));
    case Reg(mit::Register::kTorqueMax):
      return mit::Parameter::FromFloat(static_cast<float>(ranges_.torque_max_Nm));
    default:
      return 0;
  }
}

bool SimulatedMitMotor::WriteRegister(std::uint8_t reg, std::uint32_t value) noexcept {
  const float f = std::bit_cast<float>(value);
  const bool positive = std::isfinite(f) && f > 0.0F;
  switch (reg) {
    case Reg(mit::Register::kMasterId):
      if (value == 0 || value > proto::can::kMaxStandardId) return false;
      master_id_ = value;
      return true;
    case Reg(mit::Register::kTimeout):
      timeout_counts_ = value;
      return true;
    case Reg(mit::Register::kControlMode):
      if (value < 1 || value > 4) return false;
      control_mode_ = value;
      return true;
    case Reg(mit::Register::kPositionMax):
      if (!positive) return false;
      ranges_.position_max_rad = static_cast<double>(f);
      return true;
    case Reg(mit::Register::kVelocityMax):
      if (!positive) return false;
      ranges_.velocity_max_rad_per_s = static_cast<double>(f);
      return true;
    case Reg(mit::Register::kTorqueMax):
      if (!positive) return false;
      ranges_.torque_max_Nm = static_cast<double>(f);
      return true;
    default:
      return false;  // read-only or not simulated: no answer, as a refused write
  }
}

void SimulatedMitMotor::ServeParameter(const mit::Parameter& request) noexcept {
  mit::Parameter answer = request;
  switch (request.op) {
    case mit::ParameterOp::kRead:
      answer.value = ReadRegister(request.reg);
      break;
    case mit::ParameterOp::kWrite:
      if (enabled() || !WriteRegister(request.reg, request.value)) return;  // written only while disabled
      answer.value = ReadRegister(request.reg);
      break;
    case mit::ParameterOp::kSave:
      return;  // RAM is all the simulation has
  }
  proto::can::CanFrame frame;
  mit::EncodeParameter(mit::Parameter{answer.esc_id, mit::ParameterOp::kWrite, answer.reg, answer.value}, frame);
  frame.id = master_id_;
  frame.data[2] = static_cast<std::uint8_t>(request.op);
  Send(frame);
}

void SimulatedMitMotor::SendFeedback() noexcept {
  proto::can::CanFrame frame{};
  frame.id = master_id_;
  frame.fd = fd_seen_;
  frame.brs = fd_seen_;
  frame.len = 8;
  const auto clampf = [](double x, double m) { return std::clamp(x, -m, m); };
  const std::uint32_t p = mit::ToFixed(clampf(position_rad(), ranges_.position_max_rad), -ranges_.position_max_rad,
                                       ranges_.position_max_rad, mit::kPositionBits);
  const std::uint32_t v =
      mit::ToFixed(clampf(omega_rad_per_s_, ranges_.velocity_max_rad_per_s), -ranges_.velocity_max_rad_per_s,
                   ranges_.velocity_max_rad_per_s, mit::kVelocityBits);
  const std::uint32_t t = mit::ToFixed(clampf(torque_Nm_, ranges_.torque_max_Nm), -ranges_.torque_max_Nm,
                                       ranges_.torque_max_Nm, mit::kTorqueBits);
  const bool hot = injected_ == Code(mit::MotorStatus::kMosOverTemperature) ||
                   injected_ == Code(mit::MotorStatus::kCoilOverTemperature);
  const double temperature = hot ? 125.0 : config_.temperature_C;
  auto& d = frame.data;
  d[0] = static_cast<std::uint8_t>((esc_id_ & 0x0FU) | (static_cast<std::uint32_t>(status_) << 4));
  d[1] = static_cast<std::uint8_t>(p >> 8);
  d[2] = static_cast<std::uint8_t>(p & 0xFF);
  d[3] = static_cast<std::uint8_t>(v >> 4);
  d[4] = static_cast<std::uint8_t>(((v & 0xF) << 4) | (t >> 8));
  d[5] = static_cast<std::uint8_t>(t & 0xFF);
  d[6] = static_cast<std::uint8_t>(std::clamp(temperature, 0.0, 255.0));
  d[7] = static_cast<std::uint8_t>(std::clamp(temperature, 0.0, 255.0));
  Send(frame);
}

void SimulatedMitMotor::Send(const proto::can::CanFrame& frame) noexcept {
  if (silent_) return;
  if (port_.Write(frame) == transport::CanWriteStatus::kOk) ++frames_sent_;
}

}  // namespace teleop::fieldbus
