#include "teleop/fieldbus/simulated_cia402_drive.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "simulated_cia402_dictionary.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/canopen_sdo.hpp"

namespace teleop::fieldbus {

using canopen::NmtCommand;
using canopen::NmtState;
using canopen::PdoEntry;
using canopen::PdoMapping;
using proto::can::CanFrame;
namespace abort_code = canopen::sdo_abort;
namespace obj = cia402::obj;
namespace obj301 = cia402::obj301;
using simulated::RoundToI32;

namespace {

constexpr std::uint64_t kResetCommunicationTime_ns = 1'000'000;
constexpr std::uint64_t kFaultReactionTime_ns = 1'000'000;

}  // namespace

SimulatedCia402Drive::SimulatedCia402Drive(const SimulatedCia402DriveConfig& config, transport::CanPort& port)
    : config_(config), port_(port), dict_(std::make_unique<Dictionary>()) {
  if (!canopen::IsValidNodeId(config.node_id)) throw Error("simulated drive: node-ID must be 1..127");
  const SimulatedJointConfig& j = config.joint;
  if (!(j.inertia_kg_m2 > 0) || !(j.viscous_Nms_per_rad >= 0) || !(j.coulomb_Nm >= 0) || !(j.torque_lag_s >= 0) ||
      !(j.integration_step_s > 0) || !(config.position_rad_per_count > 0) ||
      !(config.velocity_rad_per_s_per_unit > 0) || config.rated_torque_mNm == 0) {
    throw Error("simulated drive: inertia, scales and rated torque must be > 0, friction and lag >= 0");
  }
  dict_->Reset(config_);
  dict_->max_torque = config.max_torque_per_mille;
  // 0x1008..0x100A as bytes, kept here so that serving them allocates nothing.
  const std::string* texts[] = {&config.device_name, &config.hardware_version, &config.software_version};
  for (std::size_t k = 0; k < strings_.size(); ++k) {
    string_sizes_[k] = std::min(texts[k]->size(), strings_[k].size());
    std::copy_n(texts[k]->begin(), string_sizes_[k], strings_[k].begin());
  }
}

SimulatedCia402Drive::~SimulatedCia402Drive() = default;

transport::CanReceiveOptions SimulatedCia402Drive::ReceiveOptions(const SimulatedCia402DriveConfig& config) {
  transport::CanReceiveOptions o;
  o.filters = {transport::CanFilter::Exact(canopen::cob::kNmt), transport::CanFilter::Exact(canopen::cob::kSync),
               transport::CanFilter::Exact(canopen::cob::kSdoRx + config.node_id),
               // RPDOs may be given any COB-ID in 0x181..0x57F: take that whole range, sort out in software.
               transport::CanFilter::Masked(0x100, 0x700), transport::CanFilter::Masked(0x200, 0x700),
               transport::CanFilter::Masked(0x300, 0x700), transport::CanFilter::Masked(0x400, 0x700),
               transport::CanFilter::Masked(0x500, 0x700),
               // Heartbeats (the host's, for the consumer).
               transport::CanFilter::Masked(canopen::cob::kHeartbeat, 0x780)};
  return o;
}

void SimulatedCia402Drive::SetSilent(bool silent) noexcept { silent_ = silent; }
void SimulatedCia402Drive::SetHeartbeatMuted(bool muted) noexcept { heartbeat_muted_ = muted; }
void SimulatedCia402Drive::DropSdoResponses(int count) noexcept { drop_sdo_ = std::max(0, count); }
void SimulatedCia402Drive::AbortObject(std::uint16_t index, std::uint32_t code) noexcept {
  for (AbortedObject& a : aborted_) {
    if (a.index == index) a = AbortedObject{};
  }
  if (code == 0 || index == 0) return;
  for (AbortedObject& a : aborted_) {
    if (a.index == 0) {
      a = AbortedObject{index, code};
      return;
    }
  }
}
void SimulatedCia402Drive::SetJointState(double position_rad, double velocity_rad_per_s) noexcept {
  position_rad_ = position_rad;
  velocity_rad_per_s_ = velocity_rad_per_s;
}
void SimulatedCia402Drive::SetExternalTorque(double torque_Nm) noexcept { external_torque_Nm_ = torque_Nm; }

void SimulatedCia402Drive::InjectFault(std::uint16_t error_code) noexcept { EnterFault(error_code); }

std::uint32_t SimulatedCia402Drive::consumer_heartbeat() const noexcept { return dict_->consumer_heartbeat; }

void SimulatedCia402Drive::ForceDisable() noexcept {
  if (machine_.state() != cia402::DriveState::kFault && machine_.state() != cia402::DriveState::kFaultReactionActive) {
    (void)machine_.Apply(cia402::cw::kCmdDisableVoltage, true);
  }
}

const PdoMapping& SimulatedCia402Drive::rpdo(int n) const noexcept {
  return dict_->rpdo[static_cast<std::size_t>(std::clamp(n, 1, 4) - 1)];
}
const PdoMapping& SimulatedCia402Drive::tpdo(int n) const noexcept {
  return dict_->tpdo[static_cast<std::size_t>(std::clamp(n, 1, 4) - 1)];
}

double SimulatedCia402Drive::TorqueLimit_Nm() const noexcept {
  return std::min<int>(dict_->max_torque, 32767) * 1e-3 * config_.rated_torque_mNm * 1e-3;
}

double SimulatedCia402Drive::VelocityLoop(double velocity_ref, double h) noexcept {
  const SimulatedLoopConfig& l = config_.loops;
  const double limit = TorqueLimit_Nm();
  const double error = velocity_ref - velocity_rad_per_s_;
  const double unclamped = l.velocity_kp_Nms_per_rad * error + velocity_integral_Nm_;
  // Conditional integration (anti-windup): the integral grows only while the output is not at the limit.
  if (std::abs(unclamped) < limit) {
    velocity_integral_Nm_ = std::clamp(velocity_integral_Nm_ + l.velocity_ki_Nm_per_rad * error * h, -limit, limit);
  }
  return std::clamp(unclamped, -limit, limit);
}

double SimulatedCia402Drive::LoopTorque(double h) noexcept {
  const cia402::DriveState st = machine_.state();
  const bool enabled = st == cia402::DriveState::kOperationEnabled;
  const bool halted = enabled && (controlword_ & cia402::cw::kHalt) != 0;
  const SimulatedLoopConfig& l = config_.loops;
  if (enabled && !halted) {
    stopping_ = false;
    holding_ = false;
    switch (mode_) {
      case cia402::kModeCyclicSynchronousTorque:
        velocity_integral_Nm_ = 0.0;
        return commanded_torque_Nm();
      case cia402::kModeCyclicSynchronousVelocity:
        return VelocityLoop(target_velocity_ * config_.velocity_rad_per_s_per_unit, h);
      case cia402::kModeCyclicSynchronousPosition:
        return VelocityLoop(l.position_kp_per_s * (target_position_ * config_.position_rad_per_count - position_rad_),
                            h);
      default:
        return 0.0;
    }
  }
  if (halted || st == cia402::DriveState::kQuickStopActive) {
    // The deceleration: halt by 0x605D (1 profile, 2 quick stop, 3/4 at the torque limit), quick stop by 0x605A
    // (1/5 profile, 2/6 quick stop, 3/4/7/8 at the torque limit).
    const int option = halted ? dict_->halt_option : dict_->quick_stop_option;
    const int ramp = halted ? option : (option > 4 ? option - 4 : option);
    double decel = std::numeric_limits<double>::infinity();
    if (ramp == 1) decel = dict_->profile_deceleration * config_.velocity_rad_per_s_per_unit;
    if (ramp == 2) decel = dict_->quick_stop_deceleration * config_.velocity_rad_per_s_per_unit;
    if (!stopping_) {
      stopping_ = true;
      holding_ = false;
      stop_velocity_ref_ = velocity_rad_per_s_;
    }
    const double step = decel * h;
    stop_velocity_ref_ =
        std::abs(stop_velocity_ref_) <= step ? 0.0 : stop_velocity_ref_ - std::copysign(step, stop_velocity_ref_);
    if (!holding_ && stop_velocity_ref_ == 0.0 && std::abs(velocity_rad_per_s_) < l.standstill_rad_per_s) {
      holding_ = true;
      hold_position_rad_ = position_rad_;
      // Quick stop options 1..4 end in Switch On Disabled once at rest (transition 12); 5..8 stay and hold.
      if (!halted && option >= 1 && option <= 4) {
        (void)machine_.Apply(cia402::cw::kCmdDisableVoltage, true);
        stopping_ = false;
        holding_ = false;
        velocity_integral_Nm_ = 0.0;
        return 0.0;
      }
    }
    return VelocityLoop(holding_ ? l.position_kp_per_s * (hold_position_rad_ - position_rad_) : stop_velocity_ref_, h);
  }
  stopping_ = false;
  holding_ = false;
  velocity_integral_Nm_ = 0.0;
  return 0.0;
}

double SimulatedCia402Drive::commanded_torque_Nm() const noexcept {
  if (machine_.state() != cia402::DriveState::kOperationEnabled || mode_ != cia402::kModeCyclicSynchronousTorque ||
      (controlword_ & cia402::cw::kHalt) != 0) {
    return machine_.state() == cia402::DriveState::kOperationEnabled ||
                   machine_.state() == cia402::DriveState::kQuickStopActive
               ? command_Nm_
               : 0.0;
  }
  const int limit = std::min<int>(dict_->max_torque, 32767);
  const int per_mille = std::clamp<int>(target_torque_, -limit, limit);
  return per_mille * 1e-3 * config_.rated_torque_mNm * 1e-3;
}

void SimulatedCia402Drive::Send(const CanFrame& frame) noexcept {
  if (silent_) return;
  (void)port_.Write(frame);  // a refused frame is lost, as on a saturated bus
}

void SimulatedCia402Drive::Boot(std::uint64_t now_ns) noexcept {
  booted_ = true;
  nmt_ = NmtState::kPreOperational;
  machine_.FinishInitialisation();
  Send(canopen::EncodeHeartbeat(config_.node_id, NmtState::kBootUp));
  next_heartbeat_ns_ = now_ns + std::uint64_t{dict_->producer_heartbeat_ms} * 1'000'000;
  host_heartbeat_seen_ = false;
}

void SimulatedCia402Drive::EnterFault(std::uint16_t error_code) noexcept {
  machine_.Fault();
  // 0x1003: the newest error at sub 1 (the error code in bits 0..15, no manufacturer information).
  std::copy_backward(error_history_.begin(), error_history_.end() - 1, error_history_.end());
  error_history_[0] = error_code;
  error_history_count_ =
      static_cast<std::uint8_t>(std::min<std::size_t>(error_history_count_ + 1u, error_history_.size()));
  error_code_ = error_code;
  error_register_ =
      static_cast<std::uint8_t>(0x01 | ((error_code >> 12) == 0x8 ? 0x10 : 0) | ((error_code >> 12) == 0x2 ? 0x02 : 0));
  canopen::Emergency e{};
  e.error_code = error_code;
  e.error_register = error_register_;
  Send(canopen::EncodeEmergency(config_.node_id, e));
  ++counters_.emergencies_sent;
  boot_at_ns_ = last_ns_ + kFaultReactionTime_ns;  // reused: when the fault reaction ends
}

void SimulatedCia402Drive::Step(std::uint64_t now_ns) noexcept {
  if (!powered_) {
    powered_ = true;
    last_ns_ = now_ns;
    boot_at_ns_ = now_ns + static_cast<std::uint64_t>(std::llround(config_.boot_time_ms * 1e6));
  }
  Integrate(now_ns);
  if (!booted_ && now_ns >= boot_at_ns_) Boot(now_ns);
  if (machine_.state() == cia402::DriveState::kFaultReactionActive && now_ns >= boot_at_ns_) {
    machine_.FaultReactionDone();
  }
  CanFrame frame{};
  while (port_.Read(frame)) HandleFrame(frame, now_ns);
  if (!booted_) return;
  // SDO server: a segmented transfer whose client went silent is aborted (CiA 301 0x05040000).
  if (transfer_.phase != SdoTransfer::Phase::kIdle &&
      now_ns > transfer_.last_ns + static_cast<std::uint64_t>(std::llround(config_.sdo_server_timeout_ms * 1e6))) {
    SendSdoAbort(transfer_.index, transfer_.subindex, abort_code::kTimeout);
  }
  // Heartbeat producer.
  if (dict_->producer_heartbeat_ms > 0 && now_ns >= next_heartbeat_ns_) {
    if (!heartbeat_muted_) {
      Send(canopen::EncodeHeartbeat(config_.node_id, nmt_));
      if (!silent_) ++counters_.heartbeats_sent;
    }
    next_heartbeat_ns_ = now_ns + std::uint64_t{dict_->producer_heartbeat_ms} * 1'000'000;
  }
  // Heartbeat consumer of the host (armed by the first heartbeat, CiA 301).
  const std::uint32_t consumer_ms = dict_->consumer_heartbeat & 0xFFFFu;
  if (consumer_ms > 0 && host_heartbeat_seen_ && now_ns > host_heartbeat_ns_ + std::uint64_t{consumer_ms} * 1'000'000) {
    host_heartbeat_seen_ = false;  // one event per loss
    ++counters_.host_heartbeat_timeouts;
    EnterFault(canopen::emcy::kHeartbeatError);
  }
}

void SimulatedCia402Drive::HandleFrame(const CanFrame& frame, std::uint64_t now_ns) noexcept {
  if (frame.error || frame.extended || frame.fd || frame.remote) return;
  if (silent_) return;
  NmtCommand command{};
  std::uint8_t node = 0;
  if (canopen::DecodeNmt(frame, command, node)) {
    if (node != 0 && node != config_.node_id) return;
    ++counters_.nmt_commands;
    if (!booted_) return;
    switch (command) {
      case NmtCommand::kStart:
        nmt_ = NmtState::kOperational;
        break;
      case NmtCommand::kStop:
        nmt_ = NmtState::kStopped;
        break;
      case NmtCommand::kEnterPreOperational:
        nmt_ = NmtState::kPreOperational;
        break;
      case NmtCommand::kResetNode: {
        // Application and communication objects to their power-on values; the joint keeps moving.
        const std::uint16_t max_torque = config_.max_torque_per_mille;
        dict_->Reset(config_);
        dict_->max_torque = max_torque;
        machine_ = cia402::DriveStateMachine{};
        mode_ = 0;
        previous_display_ = 0;
        mode_display_at_ns_ = 0;
        target_torque_ = 0;
        target_position_ = 0;
        target_velocity_ = 0;
        error_code_ = 0;
        error_register_ = 0;
        booted_ = false;
        transfer_.phase = SdoTransfer::Phase::kIdle;
        boot_at_ns_ = now_ns + static_cast<std::uint64_t>(std::llround(config_.boot_time_ms * 1e6));
        break;
      }
      case NmtCommand::kResetCommunication: {
        const std::uint16_t max_torque = dict_->max_torque;
        dict_->Reset(config_);
        dict_->max_torque = max_torque;
        booted_ = false;
        transfer_.phase = SdoTransfer::Phase::kIdle;
        boot_at_ns_ = now_ns + kResetCommunicationTime_ns;
        break;
      }
    }
    return;
  }
  if (!booted_) return;
  if (frame.id == canopen::cob::kSdoRx + config_.node_id) {
    if (nmt_ != NmtState::kStopped) HandleSdo(frame, now_ns);
    return;
  }
  std::uint8_t counter = 0;
  if (canopen::DecodeSync(frame, dict_->sync_cob, counter)) {
    if (nmt_ == NmtState::kOperational) HandleSync();
    return;
  }
  NmtState state{};
  if (canopen::DecodeHeartbeat(frame, node, state)) {
    const std::uint32_t consumed = (dict_->consumer_heartbeat >> 16) & 0x7Fu;
    if (consumed != 0 && node == consumed) {
      host_heartbeat_seen_ = true;
      host_heartbeat_ns_ = now_ns;
    }
    return;
  }
  if (nmt_ != NmtState::kOperational) return;
  for (int n = 0; n < 4; ++n) {
    const auto i = static_cast<std::size_t>(n);
    if (dict_->rpdo_valid[i] && frame.id == dict_->rpdo_cob[i]) {
      HandleRpdo(n + 1, frame);
      return;
    }
  }
}

void SimulatedCia402Drive::HandleRpdo(int n, const CanFrame& frame) noexcept {
  const PdoMapping& m = dict_->rpdo[static_cast<std::size_t>(n - 1)];
  std::array<std::uint32_t, canopen::kMaxPdoEntries> values{};
  if (!canopen::UnpackPdo(m, frame, std::span<std::uint32_t>(values.data(), static_cast<std::size_t>(m.entry_count)))) {
    ++counters_.rpdos_rejected;
    canopen::Emergency e{};
    e.error_code = canopen::emcy::kPdoLength;
    e.error_register = static_cast<std::uint8_t>(error_register_ | 0x10);
    Send(canopen::EncodeEmergency(config_.node_id, e));
    ++counters_.emergencies_sent;
    return;
  }
  ++counters_.rpdos;
  for (int k = 0; k < m.entry_count; ++k) {
    const PdoEntry& e = m.entries[static_cast<std::size_t>(k)];
    const std::uint32_t v = values[static_cast<std::size_t>(k)];
    if (e.index == obj::kControlword) pending_controlword_ = static_cast<std::uint16_t>(v);
    if (e.index == obj::kTargetTorque) pending_target_torque_ = static_cast<std::int16_t>(v);
    if (e.index == obj::kTargetPosition) pending_target_position_ = static_cast<std::int32_t>(v);
    if (e.index == obj::kTargetVelocity) pending_target_velocity_ = static_cast<std::int32_t>(v);
    if (e.index == obj::kModesOfOperation) mode_ = static_cast<std::int8_t>(v);
  }
  pending_rpdo_ = true;
}

void SimulatedCia402Drive::HandleSync() noexcept {
  ++counters_.syncs;
  // Synchronous RPDOs take effect at the SYNC after their reception (CiA 301, synchronous transmission).
  if (pending_rpdo_) {
    pending_rpdo_ = false;
    target_torque_ = pending_target_torque_;
    target_position_ = pending_target_position_;
    target_velocity_ = pending_target_velocity_;
    if (pending_controlword_ != controlword_ || (pending_controlword_ & cia402::cw::kFaultReset) != 0) {
      controlword_ = pending_controlword_;
      const int t = machine_.Apply(controlword_, dict_->quick_stop_option == 0);
      if (t == 15) {
        ++counters_.fault_resets;
        error_code_ = 0;
        error_register_ = 0;
        Send(canopen::EncodeEmergency(config_.node_id, canopen::Emergency{}));
        ++counters_.emergencies_sent;
      }
    }
  }
  for (int n = 0; n < 4; ++n) {
    const auto i = static_cast<std::size_t>(n);
    const PdoMapping& m = dict_->tpdo[i];
    if (!dict_->tpdo_valid[i] || m.entry_count == 0 || m.transmission_type > 240) continue;
    if (++dict_->tpdo_sync_count[i] < m.transmission_type) continue;
    dict_->tpdo_sync_count[i] = 0;
    std::array<std::uint32_t, canopen::kMaxPdoEntries> values{};
    for (int k = 0; k < m.entry_count; ++k) {
      const PdoEntry& e = m.entries[static_cast<std::size_t>(k)];
      std::uint32_t v = 0;
      switch (e.index) {
        case obj::kStatusword:
          v = Statusword();
          break;
        case obj::kPositionActual:
          v = static_cast<std::uint32_t>(RoundToI32(position_rad_ / config_.position_rad_per_count));
          break;
        case obj::kVelocityActual:
          v = static_cast<std::uint32_t>(RoundToI32(velocity_rad_per_s_ / config_.velocity_rad_per_s_per_unit));
          break;
        case obj::kTorqueActual:
          v = static_cast<std::uint32_t>(RoundToI32(applied_torque_Nm_ / (config_.rated_torque_mNm * 1e-6)));
          break;
        case obj::kModesOfOperationDisplay:
          v = static_cast<std::uint8_t>(DisplayedMode());
          break;
        default:
          break;
      }
      values[static_cast<std::size_t>(k)] = v;
    }
    CanFrame f{};
    if (canopen::PackPdo(m, dict_->tpdo_cob[i],
                         std::span<const std::uint32_t>(values.data(), static_cast<std::size_t>(m.entry_count)), f)) {
      Send(f);
      if (!silent_) ++counters_.tpdos_sent;
    }
  }
}

std::uint16_t SimulatedCia402Drive::Statusword() const noexcept {
  std::uint16_t s = machine_.Statusword() | cia402::sw::kRemote;
  const bool cyclic = mode_ == cia402::kModeCyclicSynchronousTorque ||
                      mode_ == cia402::kModeCyclicSynchronousVelocity ||
                      mode_ == cia402::kModeCyclicSynchronousPosition;
  const bool halted = (controlword_ & cia402::cw::kHalt) != 0;
  if (machine_.state() == cia402::DriveState::kOperationEnabled && cyclic && !halted) {
    s |= cia402::sw::kFollowsCommand;
  }
  // Halt: target reached (bit 10) once the drive is at rest (CiA 402, statusword of the cyclic modes).
  if (machine_.state() == cia402::DriveState::kOperationEnabled && halted && holding_) s |= cia402::sw::kTargetReached;
  return s;
}

void SimulatedCia402Drive::Integrate(std::uint64_t now_ns) noexcept {
  if (now_ns <= last_ns_) return;
  const SimulatedJointConfig& j = config_.joint;
  double remaining_s = static_cast<double>(now_ns - last_ns_) * 1e-9;
  last_ns_ = now_ns;
  while (remaining_s > 0.0) {
    const double h = std::min(remaining_s, j.integration_step_s);
    remaining_s -= h;
    const double command_Nm = LoopTorque(h);
    command_Nm_ = command_Nm;
    applied_torque_Nm_ += j.torque_lag_s > 0.0
                              ? (command_Nm - applied_torque_Nm_) * (1.0 - std::exp(-h / j.torque_lag_s))
                              : command_Nm - applied_torque_Nm_;
    if (j.external_shaft) continue;  // the shaft is moved from outside (SetJointState)
    const double drive_Nm = applied_torque_Nm_ + external_torque_Nm_ - j.viscous_Nms_per_rad * velocity_rad_per_s_;
    if (velocity_rad_per_s_ == 0.0 && std::abs(drive_Nm) <= j.coulomb_Nm) continue;  // sticks
    const double direction =
        velocity_rad_per_s_ != 0.0 ? std::copysign(1.0, velocity_rad_per_s_) : std::copysign(1.0, drive_Nm);
    const double v_next = velocity_rad_per_s_ + (drive_Nm - j.coulomb_Nm * direction) / j.inertia_kg_m2 * h;
    // Friction stops the joint; it does not reverse it within a step.
    const bool stops =
        velocity_rad_per_s_ != 0.0 && v_next * velocity_rad_per_s_ < 0.0 && std::abs(drive_Nm) <= j.coulomb_Nm;
    const double v_new = stops ? 0.0 : v_next;
    position_rad_ += 0.5 * (velocity_rad_per_s_ + v_new) * h;
    velocity_rad_per_s_ = v_new;
  }
}

}  // namespace teleop::fieldbus
