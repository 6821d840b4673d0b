// The arm's joints on MIT-mode CAN motors (mit_joint_bus.hpp).

#include "mit_joint_bus.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::device::arm {

namespace mit = proto::can::mit;

class MitJointBus::Joint final : public JointActuator {
 public:
  explicit Joint(const MitJointConfig& config) : config_(config) {}

  void Read(JointSample& out) noexcept override { out = sample_; }
  void WriteTorque(double torque_Nm) noexcept override { torque_Nm_ = torque_Nm; }
  void WriteTarget(double position, double velocity) noexcept override {
    target_position_ = position;
    target_velocity_ = velocity;
    has_target_ = true;
  }

  /// The motor-side command for the joint torque written (and the target, control: pd).
  mit::Command MotorCommand(MitControl control) noexcept {
    const MitJointConfig& c = config_;
    mit::Command cmd;
    cmd.torque_Nm = c.sign * torque_Nm_ / c.gear_ratio;
    if (control == MitControl::kPd) {
      const double q_t = has_target_ ? target_position_ : sample_.position;
      const double v_t = has_target_ ? target_velocity_ : 0.0;
      cmd.position_rad = c.sign * c.gear_ratio * (q_t - c.offset_rad);
      cmd.velocity_rad_per_s = c.sign * c.gear_ratio * v_t;
      cmd.kp_Nm_per_rad = c.kp_Nm_per_rad / (c.gear_ratio * c.gear_ratio);
      cmd.kd_Nm_s_per_rad = c.kd_Nms_per_rad / (c.gear_ratio * c.gear_ratio);
    }
    has_target_ = false;
    command_ = cmd;
    return cmd;
  }

  /// The joint's sample from the motor's newest feedback; a fault found here is latched until ClearFault.
  void Update(const fieldbus::MitMotorState& s, const MitJointBusConfig& bus, bool check_disabled,
              int exchanges_since_enable) noexcept {
    const MitJointConfig& c = config_;
    if (s.answered && s.feedback.status == static_cast<std::uint8_t>(mit::MotorStatus::kEnabled)) {
      enabled_seen_ = true;
    }
    if (!s.answered) {
      sample_.position = std::numeric_limits<double>::quiet_NaN();
      sample_.velocity = std::numeric_limits<double>::quiet_NaN();
    } else {
      const mit::Feedback& fb = s.feedback;
      sample_.position = c.offset_rad + c.sign * fb.position_rad / c.gear_ratio;
      sample_.velocity = c.sign * fb.velocity_rad_per_s / c.gear_ratio;
      sample_.torque_Nm = c.sign * c.gear_ratio * fb.torque_Nm;
      sample_.temperature_C = std::max(fb.mos_temperature_C, fb.rotor_temperature_C);
      sample_.temperature_warning = sample_.temperature_C >= bus.temperature_warning_C;
    }
    if (sample_.fault) return;  // latched: the first cause stays the named one
    if (s.missing_in_a_row >= bus.missing_limit) {
      Latch(JointFaultKind::kNoReply, kMitFaultNoReply);
    } else if (s.answered && mit::IsFault(s.feedback.status)) {
      const auto code = static_cast<mit::MotorStatus>(s.feedback.status);
      const JointFaultKind kind =
          code == mit::MotorStatus::kMosOverTemperature || code == mit::MotorStatus::kCoilOverTemperature
              ? JointFaultKind::kOverTemperature
          : code == mit::MotorStatus::kCommunicationLost ? JointFaultKind::kNoReply
                                                         : JointFaultKind::kDriver;
      Latch(kind, s.feedback.status);
    } else if (s.answered && sample_.temperature_C >= bus.temperature_fault_C) {
      Latch(JointFaultKind::kOverTemperature, kMitFaultHostTemperature);
    } else if (check_disabled && s.answered &&
               s.feedback.status == static_cast<std::uint8_t>(mit::MotorStatus::kDisabled)) {
      // Before the first feedback that shows it enabled, the newest may still be the answer to Activate's disable
      // (the first exchange carries the enables too, and its replies can come a cycle late): a motor that answers
      // but has not shown enabled within missing_limit exchanges never enabled, and does not run.
      if (enabled_seen_) {
        Latch(JointFaultKind::kDriver, kMitFaultDisabled);
      } else if (exchanges_since_enable >= bus.missing_limit) {
        Latch(JointFaultKind::kDriver, kMitFaultNeverEnabled);
      }
    }
  }
  void ClearFault() noexcept {
    enabled_seen_ = false;
    sample_.fault = false;
    sample_.fault_code = 0;
    torque_Nm_ = 0.0;
    has_target_ = false;
  }
  bool fault() const noexcept { return sample_.fault; }
  const mit::Command& command() const noexcept { return command_; }

 private:
  void Latch(JointFaultKind kind, std::uint32_t code) noexcept {
    sample_.fault = true;
    sample_.fault_kind = kind;
    sample_.fault_code = code;
  }

  MitJointConfig config_;
  JointSample sample_;
  mit::Command command_{};
  double torque_Nm_ = 0.0;
  double target_position_ = 0.0;
  double target_velocity_ = 0.0;
  bool has_target_ = false;
  bool enabled_seen_ = false;  ///< A feedback showed the motor enabled since the last ClearFault (Activate).
};

void CheckMitBusLoad(const MitJointBusConfig& config, const std::string& where) {
  const double rate_hz = config.rate_hz;
  if (rate_hz <= 0.0 || config.simulated) return;  // the in-process simulated bus has no wire to budget
  const int n = static_cast<int>(config.joints.size());
  const mit::MitBusLoad load =
      mit::ComputeMitBusLoad(n, rate_hz, config.fd, config.fd, config.nominal_bitrate_bit_per_s,
                             config.data_bitrate_bit_per_s, config.max_bus_load);
  if (load.load <= config.max_bus_load) return;
  const mit::MitBusLoad fd = mit::ComputeMitBusLoad(n, rate_hz, true, true, config.nominal_bitrate_bit_per_s,
                                                    std::max(config.data_bitrate_bit_per_s, 5e6), config.max_bus_load);
  const double max_rate_hz = config.max_bus_load / (static_cast<double>(n) * load.exchange_time_s);
  const int buses = load.max_motors > 0 ? (n + load.max_motors - 1) / load.max_motors : n;
  std::string what_fits =
      fmt::format("{} motors per bus at {} Hz ({} buses for {} joints), or a rate of at most {:.0f} Hz",
                  load.max_motors, rate_hz, buses, n, std::floor(max_rate_hz));
  if (!config.fd || config.data_bitrate_bit_per_s < 5e6) {
    what_fits = fmt::format("CAN FD with a {:.0f} Mbit/s data phase (load {:.2f}{}), or {}",
                            std::max(config.data_bitrate_bit_per_s, 5e6) / 1e6, fd.load,
                            fd.load <= config.max_bus_load ? "" : ", does not fit either", what_fits);
  }
  throw Error(fmt::format(
      "{}: {} MIT motors at {} Hz, a command and a reply each, load this {} bus ({:.0f} kbit/s{}) to {:.2f}, above "
      "the budget {:.2f} (max_bus_load); what fits: {}",
      where, n, rate_hz, config.fd ? "CAN FD" : "classic CAN", config.nominal_bitrate_bit_per_s / 1e3,
      config.fd ? fmt::format(", data {:.0f} kbit/s", config.data_bitrate_bit_per_s / 1e3) : std::string(), load.load,
      config.max_bus_load, what_fits));
}

transport::CanReceiveOptions MitJointBus::ReceiveOptions(const MitJointBusConfig& config) {
  const std::vector<fieldbus::MitMotorConfig> motors = Motors(config, {});
  transport::CanReceiveOptions o = fieldbus::MitMotorBus::ReceiveOptions(motors);
  o.fd = config.fd;
  return o;
}

std::vector<fieldbus::MitMotorConfig> MitJointBus::Motors(const MitJointBusConfig& config,
                                                          const std::vector<std::string>& joint_names) {
  std::vector<fieldbus::MitMotorConfig> motors;
  for (std::size_t i = 0; i < config.joints.size(); ++i) {
    const MitJointConfig& j = config.joints[i];
    fieldbus::MitMotorConfig m;
    m.name = fmt::format("joint {} '{}' ({})", i + 1, i < joint_names.size() ? joint_names[i] : "", j.model);
    m.esc_id = j.esc_id;
    m.master_id = j.master_id;
    m.ranges = j.motor.ranges;
    motors.push_back(m);
  }
  return motors;
}

MitJointBus::MitJointBus(MitJointBusConfig config, std::unique_ptr<MitPlant> plant,
                         std::unique_ptr<transport::CanPort> port, std::vector<std::string> joint_names)
    : config_(std::move(config)), plant_(std::move(plant)), port_(std::move(port)), names_(std::move(joint_names)) {
  if (config_.joints.empty()) throw Error("arm: actuators mit with no joints");
  for (std::size_t i = 0; i < config_.joints.size(); ++i) {
    const MitJointConfig& j = config_.joints[i];
    if (!(j.gear_ratio > 0.0) || !std::isfinite(j.gear_ratio) || (j.sign != 1.0 && j.sign != -1.0)) {
      throw Error(fmt::format("arm: MIT joint {}: gear_ratio must be > 0 and sign +1 or -1", i + 1));
    }
  }
  if (config_.missing_limit < 1) throw Error("arm: mit.missing_limit must be at least 1");
  bus_ = std::make_unique<fieldbus::MitMotorBus>(*port_, Motors(config_, names_), config_.fd,
                                                 plant_ != nullptr ? plant_->timebase() : fieldbus::Timebase::Steady());
  for (const MitJointConfig& j : config_.joints) joints_.push_back(std::make_unique<Joint>(j));
}

MitJointBus::~MitJointBus() = default;

JointActuator& MitJointBus::joint(int i) noexcept { return *joints_[static_cast<std::size_t>(i)]; }

const mit::Command& MitJointBus::command(int i) const noexcept {
  return joints_[static_cast<std::size_t>(i)]->command();
}

std::string_view MitJointBus::FaultName(std::uint32_t fault_code) const noexcept {
  switch (fault_code) {
    case kMitFaultNoReply:
      return "the motor stopped answering (mit.missing_limit exchanges in a row without a reply)";
    case kMitFaultHostTemperature:
      return "over temperature (at or above mit.temperature_fault_C)";
    case kMitFaultDisabled:
      return "the motor reports disabled while the arm is active (power lost, or enabled by no one)";
    case kMitFaultNeverEnabled:
      return "the motor never enabled: it answers, but reported disabled for mit.missing_limit exchanges after its "
             "enable (its control mode, its driver stage or its firmware refuse the enable)";
    default:
      return fault_code <= 0xF ? mit::StatusName(static_cast<std::uint8_t>(fault_code)) : "unknown fault";
  }
}

void MitJointBus::Configure() {
  const double timeout_s = config_.answer_timeout_ms * 1e-3;
  const auto name = [this](std::size_t i) { return bus_->config(i).name; };
  const auto silent = bus_->SendSpecialAndWait(mit::Special::kDisable, timeout_s);
  if (!silent.empty()) {
    std::string list;
    for (const std::size_t i : silent) {
      list += fmt::format("{}{} (esc_id 0x{:X}, master id 0x{:X})", list.empty() ? "" : ", ", name(i),
                          bus_->config(i).esc_id, bus_->config(i).master_id);
    }
    throw Error(
        fmt::format("arm: no answer within {} ms from {} on {}: powered, on this bus, at these ids? "
                    "(teleop-motor scan lists what answers)",
                    config_.answer_timeout_ms, list, port_->Describe()));
  }
  const auto counts = static_cast<std::uint32_t>(std::lround(config_.motor_timeout_ms * 1e-3 / mit::kTimeoutCount_s));
  for (std::size_t i = 0; i < bus_->size(); ++i) {
    bus_->VerifyRanges(i, timeout_s);
    const auto mode = bus_->ReadRegister(i, static_cast<std::uint8_t>(mit::Register::kControlMode), timeout_s);
    if (!mode || *mode != mit::kControlModeMit) {
      throw Error(fmt::format(
          "arm: {} (esc_id 0x{:X}): control mode {} is not MIT (1): teleop-motor param write {} "
          "control_mode 1",
          name(i), bus_->config(i).esc_id, mode ? std::to_string(*mode) : "unread", bus_->config(i).esc_id));
    }
    if (!bus_->WriteRegister(i, static_cast<std::uint8_t>(mit::Register::kTimeout), counts, timeout_s)) {
      throw Error(
          fmt::format("arm: {} (esc_id 0x{:X}): writing its CAN timeout (register 9 = {} counts, {} ms) "
                      "was not confirmed",
                      name(i), bus_->config(i).esc_id, counts, config_.motor_timeout_ms));
    }
  }
  // A feedback of every motor, so the joints read a position before activation.
  (void)bus_->SendSpecialAndWait(mit::Special::kDisable, timeout_s);
  UpdateSamples();
}

void MitJointBus::Activate() {
  const double timeout_s = config_.answer_timeout_ms * 1e-3;
  bus_->Drain();
  for (std::size_t i = 0; i < bus_->size(); ++i) {
    const fieldbus::MitMotorState& s = bus_->state(i);
    if (s.answered && mit::IsFault(s.feedback.status)) {
      throw Error(
          fmt::format("arm: {} (esc_id 0x{:X}) reports {} (code 0x{:X}): clear it once the cause is gone "
                      "(teleop-motor clear {})",
                      bus_->config(i).name, bus_->config(i).esc_id, mit::StatusName(s.feedback.status),
                      s.feedback.status, bus_->config(i).esc_id));
    }
  }
  for (auto& j : joints_) j->ClearFault();
  const auto silent = bus_->SendSpecialAndWait(mit::Special::kEnable, timeout_s);
  for (std::size_t i = 0; i < bus_->size(); ++i) {
    const fieldbus::MitMotorState& s = bus_->state(i);
    const bool no_answer = std::find(silent.begin(), silent.end(), i) != silent.end();
    if (no_answer || s.feedback.status != static_cast<std::uint8_t>(mit::MotorStatus::kEnabled)) {
      (void)bus_->SendSpecialAndWait(mit::Special::kDisable, timeout_s);
      throw Error(fmt::format(
          "arm: {} (esc_id 0x{:X}) did not enable: {}", bus_->config(i).name, bus_->config(i).esc_id,
          no_answer
              ? fmt::format("no answer within {} ms", config_.answer_timeout_ms)
              : fmt::format("it reports {} (code 0x{:X})", mit::StatusName(s.feedback.status), s.feedback.status)));
    }
  }
  // Each motor's own CAN timeout (register 9) counts from the last frame it received, but only while enabled: the
  // loop's first cycle may come long after this (the peer, the start-up check), so the motors go back to disabled
  // here and the first Exchange enables them again right before their first command.
  if (!bus_->SendSpecialAndWait(mit::Special::kDisable, timeout_s).empty()) {
    throw Error(fmt::format("arm: a motor did not answer the disable after its enable within {} ms",
                            config_.answer_timeout_ms));
  }
  enable_pending_ = true;
  faulted_ = false;
  active_ = true;
  UpdateSamples();
}

void MitJointBus::Deactivate() noexcept {
  active_ = false;
  enable_pending_ = false;
  try {
    (void)bus_->SendSpecialAndWait(mit::Special::kDisable, config_.answer_timeout_ms * 1e-3);
  } catch (...) {  // set-up allocation failed: disable without waiting
    for (std::size_t i = 0; i < bus_->size(); ++i) bus_->SendSpecial(i, mit::Special::kDisable);
  }
}

void MitJointBus::Fault() noexcept {
  faulted_ = true;
  for (std::size_t i = 0; i < bus_->size(); ++i) bus_->SendSpecial(i, mit::Special::kDisable);
}

void MitJointBus::UpdateSamples() noexcept {
  bool any = false;
  for (std::size_t i = 0; i < joints_.size(); ++i) {
    joints_[i]->Update(bus_->state(i), config_, active_ && !faulted_ && !enable_pending_, exchanges_since_enable_);
    any = any || joints_[i]->fault();
  }
  if (any && active_ && !faulted_) Fault();
}

void MitJointBus::Exchange(double period_s) noexcept {
  if (active_ && !faulted_) {
    if (exchanges_since_enable_ < config_.missing_limit) ++exchanges_since_enable_;
    if (enable_pending_) {
      // The first cycle: every motor's enable instead of its command (Activate), answered as a command is; the
      // commands follow from the next cycle on, so the motor's timeout counts from this exchange.
      bus_->Drain();
      for (std::size_t i = 0; i < bus_->size(); ++i) bus_->SendSpecial(i, mit::Special::kEnable);
      enable_pending_ = false;
      exchanges_since_enable_ = 0;
    } else {
      for (std::size_t i = 0; i < joints_.size(); ++i) {
        bus_->SetCommand(i, joints_[i]->MotorCommand(config_.control));
      }
      (void)bus_->Exchange();  // a failed write is a reply that does not come: counted as missing
    }
  } else if (faulted_) {
    for (std::size_t i = 0; i < bus_->size(); ++i) bus_->SendSpecial(i, mit::Special::kDisable);
  }
  if (plant_ != nullptr) {
    plant_->Advance(period_s);
  } else if (config_.reply_wait_us > 0.0) {
    const std::int64_t deadline = port_->now_ns() + static_cast<std::int64_t>(config_.reply_wait_us * 1e3);
    while (!bus_->AllAnswered() && port_->WaitReadable(deadline)) bus_->Drain();
  }
  bus_->Drain();
  UpdateSamples();
}

}  // namespace teleop::device::arm
