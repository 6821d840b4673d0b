#include "teleop/fieldbus/simulated_cia402_drive.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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

namespace {

constexpr std::uint64_t kResetCommunicationTime_ns = 1'000'000;
constexpr std::uint64_t kFaultReactionTime_ns = 1'000'000;
/// A manufacturer-specific VISIBLE_STRING (read-write, up to 32 bytes): the object segmented downloads are tested on.
constexpr std::uint16_t kLabelObject = 0x2000;

PdoMapping Mapping(int number, std::initializer_list<PdoEntry> entries) {
  PdoMapping m{};
  m.number = number;
  m.transmission_type = 1;
  for (const PdoEntry& e : entries) m.entries[static_cast<std::size_t>(m.entry_count++)] = e;
  return m;
}

/// Size in bytes of the objects the drive can map, 0 when not mappable in that direction.
int MappableBytes(std::uint16_t index, std::uint8_t subindex, bool tpdo) noexcept {
  if (subindex != 0) return 0;
  if (tpdo) {
    switch (index) {
      case obj::kStatusword:
      case obj::kTorqueActual:
        return 2;
      case obj::kPositionActual:
      case obj::kVelocityActual:
        return 4;
      case obj::kModesOfOperationDisplay:
        return 1;
      default:
        return 0;
    }
  }
  switch (index) {
    case obj::kControlword:
    case obj::kTargetTorque:
      return 2;
    case obj::kTargetPosition:
    case obj::kTargetVelocity:
      return 4;
    case obj::kModesOfOperation:
      return 1;
    default:
      return 0;
  }
}

std::int32_t RoundToI32(double x) noexcept {
  if (!std::isfinite(x)) return 0;
  return static_cast<std::int32_t>(std::clamp(std::llround(x), -2147483647LL, 2147483647LL));
}

}  // namespace

/// The communication objects the client configures (CiA 301 0x1000..0x1FFF), with their power-on values.
struct SimulatedCia402Drive::Dictionary {
  std::array<PdoMapping, 4> rpdo{};
  std::array<PdoMapping, 4> tpdo{};
  std::array<bool, 4> rpdo_valid{};
  std::array<bool, 4> tpdo_valid{};
  std::array<std::uint32_t, 4> rpdo_cob{};
  std::array<std::uint32_t, 4> tpdo_cob{};
  std::array<int, 4> tpdo_sync_count{};
  std::uint32_t sync_cob = canopen::cob::kSync;
  std::uint32_t cycle_period_us = 0;
  std::uint32_t consumer_heartbeat = 0;  // node << 16 | ms
  std::uint16_t producer_heartbeat_ms = 0;
  std::int16_t quick_stop_option = 2;
  std::int16_t fault_reaction_option = 2;
  std::uint16_t max_torque = 1000;
  std::int16_t halt_option = 1;
  std::uint32_t profile_deceleration = 0;     // velocity units per s
  std::uint32_t quick_stop_deceleration = 0;  // velocity units per s

  void Reset(const SimulatedCia402DriveConfig& c) {
    // A factory mapping unlike the client's (statusword alone in TPDO1, position alone in TPDO2, no torque in
    // RPDO1): a client that does not write its own mapping misreads nothing, it is refused on length.
    rpdo = {Mapping(1, {{obj::kControlword, 0, 16}}),
            Mapping(2, {{obj::kControlword, 0, 16}, {obj::kTargetTorque, 0, 16}}), Mapping(3, {}), Mapping(4, {})};
    tpdo = {Mapping(1, {{obj::kStatusword, 0, 16}}), Mapping(2, {{obj::kPositionActual, 0, 32}}), Mapping(3, {}),
            Mapping(4, {})};
    for (int n = 0; n < 4; ++n) {
      const auto i = static_cast<std::size_t>(n);
      rpdo_valid[i] = n < 2;
      tpdo_valid[i] = n < 2;
      rpdo_cob[i] = canopen::cob::DefaultRpdo(n + 1, c.node_id);
      tpdo_cob[i] = canopen::cob::DefaultTpdo(n + 1, c.node_id);
      tpdo_sync_count[i] = 0;
    }
    sync_cob = canopen::cob::kSync;
    cycle_period_us = 0;
    consumer_heartbeat = 0;
    producer_heartbeat_ms = c.heartbeat_period_ms;
    halt_option = 1;
    profile_deceleration =
        static_cast<std::uint32_t>(std::llround(c.profile_deceleration_rad_per_s2 / c.velocity_rad_per_s_per_unit));
    quick_stop_deceleration =
        static_cast<std::uint32_t>(std::llround(c.quick_stop_deceleration_rad_per_s2 / c.velocity_rad_per_s_per_unit));
  }
};

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

void SimulatedCia402Drive::SendSdoAbort(std::uint16_t index, std::uint8_t subindex, std::uint32_t code) noexcept {
  Send(canopen::EncodeSdoAbort(canopen::cob::kSdoTx + config_.node_id, index, subindex, code));
  ++counters_.sdo_aborts_sent;
  transfer_.phase = SdoTransfer::Phase::kIdle;
}

void SimulatedCia402Drive::FlushResetEmergency() noexcept {
  if (!reset_emcy_pending_) return;
  reset_emcy_pending_ = false;
  Send(canopen::EncodeEmergency(config_.node_id, canopen::Emergency{}));
  ++counters_.emergencies_sent;
}

bool SimulatedCia402Drive::ByteObject(std::uint16_t index, std::uint8_t subindex, std::span<const std::uint8_t>& bytes,
                                      bool& writable) const noexcept {
  if (subindex != 0) return false;
  writable = false;
  switch (index) {
    case obj301::kDeviceName:
    case obj301::kHardwareVersion:
    case obj301::kSoftwareVersion: {
      const auto k = static_cast<std::size_t>(index - obj301::kDeviceName);
      bytes = std::span<const std::uint8_t>(strings_[k].data(), string_sizes_[k]);
      return true;
    }
    case kLabelObject:
      bytes = std::span<const std::uint8_t>(label_.data(), label_size_);
      writable = true;
      return true;
    default:
      return false;
  }
}

void SimulatedCia402Drive::StoreLabel(std::span<const std::uint8_t> bytes) noexcept {
  label_size_ = std::min(bytes.size(), label_.size());
  std::copy_n(bytes.begin(), label_size_, label_.begin());
}

void SimulatedCia402Drive::HandleSdo(const CanFrame& frame, std::uint64_t now_ns) noexcept {
  using Kind = canopen::SdoMessage::Kind;
  using Phase = SdoTransfer::Phase;
  canopen::SdoMessage m{};
  if (!canopen::DecodeSdoRequest(frame, m)) return;
  ++counters_.sdo_requests;
  if (m.kind == Kind::kAbort) {  // the client ends the transfer; an abort is never answered
    transfer_.phase = Phase::kIdle;
    return;
  }
  if (drop_sdo_ > 0) {
    --drop_sdo_;
    return;
  }
  if (m.kind == Kind::kUploadSegmentRequest || m.kind == Kind::kDownloadSegmentRequest) {
    return HandleSdoSegment(m, now_ns);
  }
  if (m.kind != Kind::kUploadRequest && m.kind != Kind::kDownloadRequest &&
      m.kind != Kind::kDownloadInitiateSegmented) {
    return SendSdoAbort(m.index, m.subindex, abort_code::kBadCommand);  // block transfers, reserved specifiers
  }
  if (ignore_index_ != 0 && m.index == ignore_index_) return;
  transfer_.phase = Phase::kIdle;  // a new initiate ends a transfer the client gave up
  for (const AbortedObject& a : aborted_) {
    if (a.index != 0 && m.index == a.index) return SendSdoAbort(m.index, m.subindex, a.code);
  }
  std::span<const std::uint8_t> bytes;
  bool writable = false;
  const bool is_bytes = ByteObject(m.index, m.subindex, bytes, writable);
  if (m.kind == Kind::kUploadRequest && is_bytes) {
    if (!bytes.empty() && bytes.size() <= 4) {
      std::uint32_t value = 0;
      for (std::size_t i = bytes.size(); i > 0; --i) value = value << 8 | bytes[i - 1];
      Send(canopen::EncodeSdoUploadResponse(config_.node_id, m.index, m.subindex, value,
                                            static_cast<std::uint8_t>(bytes.size())));
      return;
    }
    transfer_ = SdoTransfer{};
    transfer_.phase = Phase::kUpload;
    transfer_.index = m.index;
    transfer_.subindex = m.subindex;
    transfer_.size = bytes.size();
    transfer_.last_ns = now_ns;
    std::copy(bytes.begin(), bytes.end(), transfer_.buffer.begin());
    Send(canopen::EncodeSdoInitiateUploadSegmented(config_.node_id, m.index, m.subindex,
                                                   static_cast<std::uint32_t>(bytes.size())));
    return;
  }
  if (is_bytes && !writable && m.kind != Kind::kUploadRequest) {
    return SendSdoAbort(m.index, m.subindex, abort_code::kReadOnly);
  }
  if (m.kind == Kind::kDownloadRequest && is_bytes) {
    std::array<std::uint8_t, 4> value{};
    for (std::size_t i = 0; i < value.size(); ++i) value[i] = static_cast<std::uint8_t>(m.value >> (8 * i));
    StoreLabel(std::span<const std::uint8_t>(value.data(), m.size));
    Send(canopen::EncodeSdoDownloadResponse(config_.node_id, m.index, m.subindex));
    return;
  }
  if (m.kind == Kind::kDownloadInitiateSegmented) {
    const std::size_t capacity = is_bytes ? label_.size() : 4;
    if (m.size_indicated && m.value > capacity) return SendSdoAbort(m.index, m.subindex, abort_code::kLengthTooHigh);
    transfer_ = SdoTransfer{};
    transfer_.phase = Phase::kDownload;
    transfer_.index = m.index;
    transfer_.subindex = m.subindex;
    transfer_.size_indicated = m.size_indicated;
    transfer_.size = m.value;
    transfer_.capacity = capacity;
    transfer_.last_ns = now_ns;
    Send(canopen::EncodeSdoDownloadResponse(config_.node_id, m.index, m.subindex));
    return;
  }
  std::uint32_t value = 0;
  std::uint8_t size = 0;
  if (const std::uint32_t code = Access(m, value, size)) return SendSdoAbort(m.index, m.subindex, code);
  if (m.kind == Kind::kUploadRequest) {
    Send(canopen::EncodeSdoUploadResponse(config_.node_id, m.index, m.subindex, value, size));
  } else {
    Send(canopen::EncodeSdoDownloadResponse(config_.node_id, m.index, m.subindex));
  }
  FlushResetEmergency();
}

void SimulatedCia402Drive::HandleSdoSegment(const canopen::SdoMessage& m, std::uint64_t now_ns) noexcept {
  using Kind = canopen::SdoMessage::Kind;
  using Phase = SdoTransfer::Phase;
  SdoTransfer& t = transfer_;
  const bool upload = m.kind == Kind::kUploadSegmentRequest;
  // A segment outside a transfer of its direction: command specifier not valid (CiA 301 abort 0x05040001).
  if (t.phase != (upload ? Phase::kUpload : Phase::kDownload)) {
    return SendSdoAbort(t.phase == Phase::kIdle ? 0 : t.index, t.phase == Phase::kIdle ? 0 : t.subindex,
                        abort_code::kBadCommand);
  }
  if (m.toggle != t.toggle) return SendSdoAbort(t.index, t.subindex, abort_code::kToggleBit);
  t.last_ns = now_ns;
  ++counters_.sdo_segments;
  if (upload) {
    const std::size_t chunk = std::min(canopen::kSdoSegmentBytes, t.size - t.offset);
    const bool last = t.offset + chunk == t.size;
    Send(canopen::EncodeSdoUploadSegment(config_.node_id, t.toggle,
                                         std::span<const std::uint8_t>(t.buffer.data() + t.offset, chunk), last));
    t.offset += chunk;
    t.toggle = !t.toggle;
    if (last) t.phase = Phase::kIdle;
    return;
  }
  if (t.offset + m.segment_size > t.capacity) return SendSdoAbort(t.index, t.subindex, abort_code::kLengthTooHigh);
  std::copy_n(m.segment.begin(), m.segment_size, t.buffer.begin() + static_cast<std::ptrdiff_t>(t.offset));
  t.offset += m.segment_size;
  if (!m.last) {
    Send(canopen::EncodeSdoDownloadSegmentResponse(config_.node_id, t.toggle));
    t.toggle = !t.toggle;
    return;
  }
  if (t.size_indicated && t.offset != t.size) return SendSdoAbort(t.index, t.subindex, abort_code::kLengthMismatch);
  std::span<const std::uint8_t> bytes;
  bool writable = false;
  if (ByteObject(t.index, t.subindex, bytes, writable)) {
    StoreLabel(std::span<const std::uint8_t>(t.buffer.data(), t.offset));
  } else {
    if (t.offset == 0) return SendSdoAbort(t.index, t.subindex, abort_code::kLengthTooLow);
    canopen::SdoMessage write{};
    write.kind = Kind::kDownloadRequest;
    write.index = t.index;
    write.subindex = t.subindex;
    write.size = static_cast<std::uint8_t>(t.offset);
    for (std::size_t i = t.offset; i > 0; --i) write.value = write.value << 8 | t.buffer[i - 1];
    std::uint32_t unused_value = 0;
    std::uint8_t unused_size = 0;
    if (const std::uint32_t code = Access(write, unused_value, unused_size)) {
      return SendSdoAbort(t.index, t.subindex, code);
    }
  }
  Send(canopen::EncodeSdoDownloadSegmentResponse(config_.node_id, t.toggle));
  t.phase = Phase::kIdle;
  FlushResetEmergency();
}

std::uint32_t SimulatedCia402Drive::Access(const canopen::SdoMessage& m, std::uint32_t& out_value,
                                           std::uint8_t& out_size) noexcept {
  auto abort = [](std::uint32_t code) { return code; };
  Dictionary& d = *dict_;
  const bool upload = m.kind == canopen::SdoMessage::Kind::kUploadRequest;
  const std::uint8_t sub = m.subindex;
  const std::uint32_t v = m.value;
  // ---- Reads ----
  auto reply = [&](std::uint32_t value, std::uint8_t size) {
    out_value = value;
    out_size = size;
    return std::uint32_t{0};
  };
  auto ok = [] { return std::uint32_t{0}; };
  // Checks the length of a download against the object's: 0 or the abort code.
  auto length = [&](std::uint8_t size) -> std::uint32_t {
    if (m.size == size) return 0;
    return m.size > size ? abort_code::kLengthTooHigh : abort_code::kLengthTooLow;
  };
  const std::uint16_t index = m.index;
  if (index >= obj301::kRpdoCommunication && index < obj301::kRpdoCommunication + 4) {
    const auto i = static_cast<std::size_t>(index - obj301::kRpdoCommunication);
    if (sub == 0) return upload ? reply(2, 1) : abort(abort_code::kReadOnly);
    if (sub == 1) {
      // No RTR here: bit 30 reads 1 and must be written 1 (devices without RTR refuse 0, as CiA 301 lets them); no
      // 29-bit identifiers; bits 0..29 are not changed while the PDO is valid (CiA 301).
      if (upload) {
        return reply(d.rpdo_cob[i] | canopen::cob::kNoRtrBit | (d.rpdo_valid[i] ? 0u : canopen::cob::kInvalidBit), 4);
      }
      if (const std::uint32_t c = length(4)) return c;
      const bool valid = (v & canopen::cob::kInvalidBit) == 0;
      if ((v & canopen::cob::kNoRtrBit) == 0 || (v & 0x3FFF'F800u) != 0) return abort(abort_code::kValueRange);
      if (valid && d.rpdo_valid[i] && (v & 0x7FFu) != d.rpdo_cob[i]) return abort(abort_code::kValueRange);
      d.rpdo_valid[i] = valid;
      d.rpdo_cob[i] = v & 0x7FFu;
      return ok();
    }
    if (sub == 2) {
      if (upload) return reply(d.rpdo[i].transmission_type, 1);
      if (const std::uint32_t c = length(1)) return c;
      if (v == 0 || (v > 240 && v < 254) || v > 255) return abort(abort_code::kValueRange);
      d.rpdo[i].transmission_type = static_cast<std::uint8_t>(v);
      return ok();
    }
    return abort(abort_code::kNoSubindex);
  }
  if (index >= obj301::kTpdoCommunication && index < obj301::kTpdoCommunication + 4) {
    const auto i = static_cast<std::size_t>(index - obj301::kTpdoCommunication);
    if (sub == 0) return upload ? reply(2, 1) : abort(abort_code::kReadOnly);
    if (sub == 1) {
      // No RTR here: bit 30 reads 1 and must be written 1 (devices without RTR refuse 0, as CiA 301 lets them); no
      // 29-bit identifiers; bits 0..29 are not changed while the PDO is valid (CiA 301).
      if (upload) {
        return reply(d.tpdo_cob[i] | canopen::cob::kNoRtrBit | (d.tpdo_valid[i] ? 0u : canopen::cob::kInvalidBit), 4);
      }
      if (const std::uint32_t c = length(4)) return c;
      const bool valid = (v & canopen::cob::kInvalidBit) == 0;
      if ((v & canopen::cob::kNoRtrBit) == 0 || (v & 0x3FFF'F800u) != 0) return abort(abort_code::kValueRange);
      if (valid && d.tpdo_valid[i] && (v & 0x7FFu) != d.tpdo_cob[i]) return abort(abort_code::kValueRange);
      d.tpdo_valid[i] = valid;
      d.tpdo_cob[i] = v & 0x7FFu;
      return ok();
    }
    if (sub == 2) {
      if (upload) return reply(d.tpdo[i].transmission_type, 1);
      if (const std::uint32_t c = length(1)) return c;
      if (v == 0 || (v > 240 && v < 254) || v > 255) return abort(abort_code::kValueRange);
      d.tpdo[i].transmission_type = static_cast<std::uint8_t>(v);
      d.tpdo_sync_count[i] = 0;
      return ok();
    }
    return abort(abort_code::kNoSubindex);
  }
  const bool rpdo_map = index >= obj301::kRpdoMapping && index < obj301::kRpdoMapping + 4;
  const bool tpdo_map = index >= obj301::kTpdoMapping && index < obj301::kTpdoMapping + 4;
  if (rpdo_map || tpdo_map) {
    const auto i = static_cast<std::size_t>(index - (rpdo_map ? obj301::kRpdoMapping : obj301::kTpdoMapping));
    PdoMapping& map = rpdo_map ? d.rpdo[i] : d.tpdo[i];
    const bool valid = rpdo_map ? d.rpdo_valid[i] : d.tpdo_valid[i];
    if (sub > canopen::kMaxPdoEntries) return abort(abort_code::kNoSubindex);
    if (upload) {
      if (sub == 0) return reply(static_cast<std::uint32_t>(map.entry_count), 1);
      return reply(map.entries[sub - 1u].MappingValue(), 4);
    }
    // CiA 301 PDO mapping procedure: the mapping changes only while the PDO is invalid; entries only while sub 0 is 0.
    if (valid) return abort(abort_code::kCannotStoreState);
    if (sub == 0) {
      if (const std::uint32_t c = length(1)) return c;
      if (v > canopen::kMaxPdoEntries) return abort(abort_code::kValueRange);
      int bits = 0;
      for (std::uint32_t k = 0; k < v; ++k) bits += map.entries[k].bits;
      if (bits > 64) return abort(abort_code::kPdoTooLong);
      map.entry_count = static_cast<int>(v);
      return ok();
    }
    if (map.entry_count != 0) return abort(abort_code::kUnsupportedAccess);
    if (const std::uint32_t c = length(4)) return c;
    const PdoEntry e = PdoEntry::FromMappingValue(v);
    const int bytes = MappableBytes(e.index, e.subindex, tpdo_map);
    if (bytes == 0) return abort(abort_code::kNotMappable);
    if (e.bits != 8 * bytes) return abort(abort_code::kLengthMismatch);
    map.entries[sub - 1u] = e;
    return ok();
  }
  switch (index) {
    case obj301::kDeviceType:
      if (sub != 0) return abort(abort_code::kNoSubindex);
      return upload ? reply(0x0002'0000u | cia402::kDeviceProfile402, 4) : abort(abort_code::kReadOnly);
    case obj301::kErrorRegister:
      if (sub != 0) return abort(abort_code::kNoSubindex);
      return upload ? reply(error_register_, 1) : abort(abort_code::kReadOnly);
    case obj301::kErrorHistory:
      if (sub == 0) {
        if (upload) return reply(error_history_count_, 1);
        if (const std::uint32_t c = length(1)) return c;
        if (v != 0) return abort(abort_code::kValueRange);  // only 0 (clear) may be written
        error_history_count_ = 0;
        return ok();
      }
      if (sub > error_history_.size()) return abort(abort_code::kNoSubindex);
      if (!upload) return abort(abort_code::kReadOnly);
      if (sub > error_history_count_) return abort(abort_code::kNoData);
      return reply(error_history_[sub - 1u], 4);
    case obj301::kCobIdSync:
      if (sub != 0) return abort(abort_code::kNoSubindex);
      if (upload) return reply(d.sync_cob, 4);
      if (const std::uint32_t c = length(4)) return c;
      d.sync_cob = v & 0x7FFu;
      return ok();
    case obj301::kCommunicationCyclePeriod:
      if (sub != 0) return abort(abort_code::kNoSubindex);
      if (upload) return reply(d.cycle_period_us, 4);
      if (const std::uint32_t c = length(4)) return c;
      d.cycle_period_us = v;
      return ok();
    case obj301::kCobIdEmcy:
      if (sub != 0) return abort(abort_code::kNoSubindex);
      return upload ? reply(canopen::cob::kEmcy + config_.node_id, 4) : abort(abort_code::kReadOnly);
    case obj301::kConsumerHeartbeatTime:
      if (sub == 0) return upload ? reply(1, 1) : abort(abort_code::kReadOnly);
      if (sub != 1) return abort(abort_code::kNoSubindex);
      if (upload) return reply(d.consumer_heartbeat, 4);
      if (const std::uint32_t c = length(4)) return c;
      d.consumer_heartbeat = v & 0x00FF'FFFFu;
      host_heartbeat_seen_ = false;  // re-armed by the next heartbeat
      return ok();
    case obj301::kProducerHeartbeatTime:
      if (sub != 0) return abort(abort_code::kNoSubindex);
      if (upload) return reply(d.producer_heartbeat_ms, 2);
      if (const std::uint32_t c = length(2)) return c;
      d.producer_heartbeat_ms = static_cast<std::uint16_t>(v);
      next_heartbeat_ns_ = last_ns_;  // the first heartbeat at once
      return ok();
    case obj301::kIdentity:
      if (!upload) return abort(abort_code::kReadOnly);
      if (sub == 0) return reply(4, 1);
      if (sub == 1) return reply(config_.vendor_id, 4);
      if (sub >= 2 && sub <= 4) return reply(sub == 2 ? 0x402u : 1u, 4);
      return abort(abort_code::kNoSubindex);
    default:
      break;
  }
  if (sub != 0) return abort(index >= 0x6000 && index <= 0x6FFF ? abort_code::kNoSubindex : abort_code::kNoObject);
  switch (index) {
    case obj::kErrorCode:
      return upload ? reply(error_code_, 2) : abort(abort_code::kReadOnly);
    case obj::kControlword:
      if (upload) return reply(controlword_, 2);
      if (const std::uint32_t c = length(2)) return c;
      controlword_ = static_cast<std::uint16_t>(v);
      if (machine_.Apply(controlword_, d.quick_stop_option == 0) == 15) {
        ++counters_.fault_resets;
        error_code_ = 0;
        error_register_ = 0;
        reset_emcy_pending_ = true;  // the "error reset" EMCY follows the SDO response
      }
      return ok();
    case obj::kStatusword:
      return upload ? reply(Statusword(), 2) : abort(abort_code::kReadOnly);
    case obj::kQuickStopOptionCode:
    case obj::kFaultReactionOptionCode: {
      std::int16_t& option = index == obj::kQuickStopOptionCode ? d.quick_stop_option : d.fault_reaction_option;
      if (upload) return reply(static_cast<std::uint16_t>(option), 2);
      if (const std::uint32_t c = length(2)) return c;
      const auto value = static_cast<std::int16_t>(v);
      if (value < 0 || value > 8) return abort(abort_code::kValueRange);
      option = value;
      return ok();
    }
    case obj::kModesOfOperation: {
      if (upload) return reply(static_cast<std::uint8_t>(mode_), 1);
      if (const std::uint32_t c = length(1)) return c;
      const auto mode = static_cast<std::int8_t>(v);
      if (mode != 0 && (config_.supported_modes & cia402::SupportedModeBit(mode)) == 0) {
        return abort(abort_code::kValueRange);  // a mode 0x6502 does not list
      }
      previous_display_ = DisplayedMode();
      mode_ = mode;
      mode_display_at_ns_ = last_ns_ + static_cast<std::uint64_t>(std::max(0.0, config_.mode_display_delay_ms) * 1e6);
      return ok();
    }
    case obj::kTargetPosition:
    case obj::kTargetVelocity: {
      std::int32_t& target = index == obj::kTargetPosition ? target_position_ : target_velocity_;
      std::int32_t& pending = index == obj::kTargetPosition ? pending_target_position_ : pending_target_velocity_;
      if (upload) return reply(static_cast<std::uint32_t>(target), 4);
      if (const std::uint32_t c = length(4)) return c;
      target = static_cast<std::int32_t>(v);
      pending = target;
      return ok();
    }
    case obj::kProfileDeceleration:
    case obj::kQuickStopDeceleration: {
      std::uint32_t& decel = index == obj::kProfileDeceleration ? d.profile_deceleration : d.quick_stop_deceleration;
      if (upload) return reply(decel, 4);
      if (const std::uint32_t c = length(4)) return c;
      decel = v;
      return ok();
    }
    case obj::kHaltOptionCode: {
      if (upload) return reply(static_cast<std::uint16_t>(d.halt_option), 2);
      if (const std::uint32_t c = length(2)) return c;
      const auto value = static_cast<std::int16_t>(v);
      if (value < 1 || value > 4) return abort(abort_code::kValueRange);
      d.halt_option = value;
      return ok();
    }
    case obj::kModesOfOperationDisplay:
      return upload ? reply(static_cast<std::uint8_t>(DisplayedMode()), 1) : abort(abort_code::kReadOnly);
    case obj::kPositionActual:
      return upload ? reply(static_cast<std::uint32_t>(RoundToI32(position_rad_ / config_.position_rad_per_count)), 4)
                    : abort(abort_code::kReadOnly);
    case obj::kVelocityActual:
      return upload ? reply(static_cast<std::uint32_t>(
                                RoundToI32(velocity_rad_per_s_ / config_.velocity_rad_per_s_per_unit)),
                            4)
                    : abort(abort_code::kReadOnly);
    case obj::kTargetTorque:
      if (upload) return reply(static_cast<std::uint16_t>(target_torque_), 2);
      if (const std::uint32_t c = length(2)) return c;
      target_torque_ = static_cast<std::int16_t>(v);
      pending_target_torque_ = target_torque_;
      return ok();
    case obj::kMaxTorque:
      if (upload) return reply(d.max_torque, 2);
      if (const std::uint32_t c = length(2)) return c;
      d.max_torque = static_cast<std::uint16_t>(v);
      return ok();
    case obj::kRatedTorque:
      return upload ? reply(config_.rated_torque_mNm, 4) : abort(abort_code::kReadOnly);
    case obj::kTorqueActual:
      return upload
                 ? reply(static_cast<std::uint16_t>(RoundToI32(applied_torque_Nm_ / (config_.rated_torque_mNm * 1e-6))),
                         2)
                 : abort(abort_code::kReadOnly);
    case obj::kSupportedDriveModes:
      return upload ? reply(config_.supported_modes, 4) : abort(abort_code::kReadOnly);
    default:
      return abort(abort_code::kNoObject);
  }
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
