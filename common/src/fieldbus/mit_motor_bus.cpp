#include "teleop/fieldbus/mit_motor_bus.hpp"

#include <fmt/format.h>

#include <cmath>
#include <set>

#include "teleop/error.hpp"

namespace teleop::fieldbus {

namespace mit = proto::can::mit;

namespace {
constexpr std::uint64_t kPollStep_ns = 200'000;  // set-up waits poll the port every 0.2 ms

bool RangesValid(const mit::MotorRanges& r) {
  for (const double x :
       {r.position_max_rad, r.velocity_max_rad_per_s, r.torque_max_Nm, r.kp_max_Nm_per_rad, r.kd_max_Nm_s_per_rad}) {
    if (!std::isfinite(x) || x <= 0) return false;
  }
  return true;
}
}  // namespace

MitMotorBus::MitMotorBus(transport::CanPort& port, std::vector<MitMotorConfig> motors, bool fd, Timebase timebase)
    : port_(port), motors_(std::move(motors)), fd_(fd), timebase_(std::move(timebase)) {
  if (motors_.empty()) throw Error("MIT motor bus: no motors configured");
  std::set<std::uint32_t> ids;
  for (const MitMotorConfig& m : motors_) {
    if (m.esc_id < 1 || m.esc_id >= mit::kParameterId || m.master_id < 1 || m.master_id >= mit::kParameterId) {
      throw Error(fmt::format("MIT motor '{}': esc_id 0x{:X} and master_id 0x{:X} must be 0x001..0x7FE", m.name,
                              m.esc_id, m.master_id));
    }
    if (!ids.insert(m.esc_id).second || !ids.insert(m.master_id).second) {
      throw Error(
          fmt::format("MIT motor '{}': id 0x{:X} or 0x{:X} is used twice on the bus (every esc_id and "
                      "master_id must be unique)",
                      m.name, m.esc_id, m.master_id));
    }
    if (!RangesValid(m.ranges)) {
      throw Error(fmt::format("MIT motor '{}': P_MAX, V_MAX, T_MAX, Kp and Kd ranges must be finite and > 0", m.name));
    }
  }
  state_.resize(motors_.size());
  commands_.resize(motors_.size());
  awaiting_.assign(motors_.size(), 0);
}

transport::CanReceiveOptions MitMotorBus::ReceiveOptions(std::span<const MitMotorConfig> motors) {
  transport::CanReceiveOptions o;
  o.filters.clear();
  for (const MitMotorConfig& m : motors) o.filters.push_back(transport::CanFilter::Exact(m.master_id));
  o.error_mask = 0;
  o.fd = true;
  return o;
}

bool MitMotorBus::Write(const proto::can::CanFrame& frame) noexcept {
  return port_.Write(frame) == transport::CanWriteStatus::kOk;
}

void MitMotorBus::Dispatch(const proto::can::CanFrame& frame) noexcept {
  for (std::size_t i = 0; i < motors_.size(); ++i) {
    const MitMotorConfig& m = motors_[i];
    if (frame.error || frame.remote || frame.extended || frame.id != m.master_id) continue;
    // A parameter answer is told from feedback only while a set-up call waits for one (mit_motor.hpp).
    if (pending_.waiting && pending_.motor == i) {
      const auto answer = mit::DecodeParameter(frame);
      if (answer && answer->esc_id == m.esc_id && answer->reg == pending_.reg) {
        pending_.answer = answer;
        return;
      }
    }
    mit::Feedback fb;
    if (mit::DecodeFeedback(frame, m.ranges, m.master_id, m.esc_id, fb) == mit::DecodeStatus::kOk) {
      MitMotorState& s = state_[i];
      s.feedback = fb;
      s.answered = true;
      s.missing_in_a_row = 0;
      awaiting_[i] = 0;
      return;
    }
  }
  ++counters_.frames_unexpected;
}

void MitMotorBus::Drain() noexcept {
  proto::can::CanFrame frame;
  while (port_.Read(frame)) Dispatch(frame);
}

bool MitMotorBus::AllAnswered() const noexcept {
  for (const char a : awaiting_) {
    if (a != 0) return false;
  }
  return true;
}

void MitMotorBus::SetCommand(std::size_t motor, const mit::Command& command) noexcept {
  if (motor < commands_.size()) commands_[motor] = command;
}

bool MitMotorBus::Exchange() noexcept {
  Drain();
  ++counters_.exchanges;
  bool ok = true;
  for (std::size_t i = 0; i < motors_.size(); ++i) {
    MitMotorState& s = state_[i];
    if (awaiting_[i] != 0) {
      ++s.missing;
      ++s.missing_in_a_row;
    }
    proto::can::CanFrame frame;
    const mit::EncodeResult r = mit::EncodeCommand(commands_[i], motors_[i].ranges, motors_[i].esc_id, frame, fd_);
    if (!r.ok) {
      ++s.refused;
      awaiting_[i] = 0;
      continue;
    }
    if (r.clamped != 0) ++s.clamped;
    if (!Write(frame)) {
      ++s.write_failures;
      ok = false;
    }
    awaiting_[i] = 1;
  }
  return ok;
}

void MitMotorBus::SendSpecial(std::size_t motor, mit::Special what) noexcept {
  if (motor >= motors_.size()) return;
  proto::can::CanFrame frame;
  mit::EncodeSpecial(what, motors_[motor].esc_id, frame, fd_);
  if (!Write(frame)) ++state_[motor].write_failures;
}

std::vector<std::size_t> MitMotorBus::SendSpecialAndWait(mit::Special what, double timeout_s,
                                                         std::optional<std::size_t> only) {
  Drain();  // replies already on their way belong to earlier frames, not to this one
  std::vector<std::size_t> targets;
  for (std::size_t i = 0; i < motors_.size(); ++i) {
    if (only && *only != i) continue;
    targets.push_back(i);
    state_[i].answered = false;
    SendSpecial(i, what);
  }
  const std::uint64_t deadline = timebase_.now_ns() + static_cast<std::uint64_t>(timeout_s * 1e9);
  // A feedback to the last command can still arrive after the special frame went out (it was on its way): an
  // answer to enable or disable counts once it shows the state left behind, so the state a caller reads afterwards
  // is the motor's answer to this frame; one that never does is still "answered" at the deadline.
  const auto left_behind = [what](std::uint8_t status) {
    if (what == mit::Special::kDisable) return status == static_cast<std::uint8_t>(mit::MotorStatus::kEnabled);
    if (what == mit::Special::kEnable) return status == static_cast<std::uint8_t>(mit::MotorStatus::kDisabled);
    return false;
  };
  std::vector<std::size_t> silent;
  while (true) {
    Drain();
    silent.clear();
    bool settled = true;
    for (const std::size_t i : targets) {
      if (!state_[i].answered) {
        silent.push_back(i);
      } else if (left_behind(state_[i].feedback.status)) {
        settled = false;
      }
    }
    if ((silent.empty() && settled) || timebase_.now_ns() >= deadline) break;
    timebase_.wait_ns(kPollStep_ns);
  }
  return silent;
}

std::optional<std::uint32_t> MitMotorBus::ReadRegister(std::size_t motor, std::uint8_t reg, double timeout_s) {
  const MitMotorConfig& m = motors_.at(motor);
  pending_ = PendingParameter{true, motor, reg, std::nullopt};
  proto::can::CanFrame frame;
  mit::EncodeParameter(mit::Parameter{static_cast<std::uint16_t>(m.esc_id), mit::ParameterOp::kRead, reg, 0}, frame);
  if (!Write(frame)) {
    pending_ = {};
    return std::nullopt;
  }
  const std::uint64_t deadline = timebase_.now_ns() + static_cast<std::uint64_t>(timeout_s * 1e9);
  while (!pending_.answer && timebase_.now_ns() < deadline) {
    timebase_.wait_ns(kPollStep_ns);
    Drain();
  }
  const auto answer = pending_.answer;
  pending_ = {};
  if (!answer) return std::nullopt;
  return answer->value;
}

bool MitMotorBus::WriteRegister(std::size_t motor, std::uint8_t reg, std::uint32_t value, double timeout_s) {
  const MitMotorConfig& m = motors_.at(motor);
  pending_ = PendingParameter{true, motor, reg, std::nullopt};
  proto::can::CanFrame frame;
  mit::EncodeParameter(mit::Parameter{static_cast<std::uint16_t>(m.esc_id), mit::ParameterOp::kWrite, reg, value},
                       frame);
  if (!Write(frame)) {
    pending_ = {};
    return false;
  }
  const std::uint64_t deadline = timebase_.now_ns() + static_cast<std::uint64_t>(timeout_s * 1e9);
  while (!pending_.answer && timebase_.now_ns() < deadline) {
    timebase_.wait_ns(kPollStep_ns);
    Drain();
  }
  const auto answer = pending_.answer;
  pending_ = {};
  return answer && answer->op == mit::ParameterOp::kWrite && answer->value == value;
}

void MitMotorBus::VerifyRanges(std::size_t motor, double timeout_s) {
  const MitMotorConfig& m = motors_.at(motor);
  struct Check {
    mit::Register reg;
    const char* name;
    double expected;
  };
  const Check checks[] = {{mit::Register::kPositionMax, "P_MAX (register 21)", m.ranges.position_max_rad},
                          {mit::Register::kVelocityMax, "V_MAX (register 22)", m.ranges.velocity_max_rad_per_s},
                          {mit::Register::kTorqueMax, "T_MAX (register 23)", m.ranges.torque_max_Nm}};
  std::string differ;  // every register that differs, so one run shows the whole mismatch
  for (const Check& c : checks) {
    const auto v = ReadRegister(motor, static_cast<std::uint8_t>(c.reg), timeout_s);
    if (!v) {
      throw Error(
          fmt::format("MIT motor '{}' (esc_id 0x{:X}): no answer to the read of {} within {} ms: is it "
                      "powered, on this bus, at this id?",
                      m.name, m.esc_id, c.name, timeout_s * 1e3));
    }
    const auto got = static_cast<double>(mit::Parameter{0, mit::ParameterOp::kRead, 0, *v}.FloatValue());
    if (!std::isfinite(got) || std::abs(got - c.expected) > 1e-4 * std::max(1.0, std::abs(c.expected))) {
      differ += fmt::format("{}{} is {} on the motor but {} in the config", differ.empty() ? "" : ", ", c.name, got,
                            c.expected);
    }
  }
  if (!differ.empty()) {
    throw Error(
        fmt::format("MIT motor '{}' (esc_id 0x{:X}): {}: every value would be scaled wrong (set the model's "
                    "ranges, or write the register with teleop-motor param write)",
                    m.name, m.esc_id, differ));
  }
}

}  // namespace teleop::fieldbus
