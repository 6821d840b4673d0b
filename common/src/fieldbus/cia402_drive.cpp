// Cia402Drive's configuration checks, its frames and its cycle (docs/cia402.md): Read drains the port and decodes the
// TPDOs through the codec (cia402_codec.hpp); WriteTorque_Nm / WriteVelocity_rad_per_s / WritePosition_rad / WriteHold
// clamp the setpoint and send the RPDOs, the SYNC and the host heartbeat. Non-blocking, no allocation, no exceptions
// in the cycle; the set-up is in cia402_drive_setup.cpp.
#include "teleop/fieldbus/cia402_drive.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::fieldbus {

using canopen::NmtState;
using canopen::PdoEntry;
using canopen::PdoMapping;
using cia402::DriveState;
using proto::can::CanFrame;
namespace obj = cia402::obj;

namespace {

/// Frames read per Read at most (bounds the cycle; the rest waits for the next one).
constexpr int kMaxFramesPerRead = 64;

PdoMapping Mapping(int number, std::initializer_list<PdoEntry> entries) {
  PdoMapping m{};
  m.number = number;
  m.transmission_type = 1;
  for (const PdoEntry& e : entries) m.entries[static_cast<std::size_t>(m.entry_count++)] = e;
  return m;
}

bool Positive(double x) noexcept { return std::isfinite(x) && x > 0.0; }

bool SameMappings(const std::vector<PdoMapping>& a, const std::vector<PdoMapping>& b) noexcept {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const PdoMapping& x = a[i];
    const PdoMapping& y = b[i];
    if (x.number != y.number || x.cob_id != y.cob_id || x.transmission_type != y.transmission_type ||
        x.entry_count != y.entry_count || !std::equal(x.mapped().begin(), x.mapped().end(), y.mapped().begin())) {
      return false;
    }
  }
  return true;
}

/// What is wrong with the node-IDs, periods and timeouts of `config`; empty when nothing.
std::string TimingError(const Cia402DriveConfig& config) {
  if (!canopen::IsValidNodeId(config.node_id)) return "node_id must be 1..127";
  if (config.host_node_id > canopen::kMaxNodeId || config.host_node_id == config.node_id) {
    return "host_node_id must be 0 (no host heartbeat) or 1..127 and differ from node_id";
  }
  if (!Positive(config.cycle_period_s) || config.cycle_period_s > 4.0) return "cycle_period_s must be in (0, 4] s";
  if (!(config.host_heartbeat_period_ms >= 0.0) || config.host_heartbeat_period_ms > 65535.0) {
    return "host_heartbeat_period_ms must be 0..65535";
  }
  if (!(config.drive_heartbeat_period_ms >= 0.0) || config.drive_heartbeat_period_ms > 65535.0) {
    return "drive_heartbeat_period_ms must be 0..65535";
  }
  if (config.drive_heartbeat_period_ms > 0.0 && !(config.heartbeat_timeout_ms > config.drive_heartbeat_period_ms)) {
    return fmt::format("heartbeat_timeout_ms ({:g}) must exceed drive_heartbeat_period_ms ({:g})",
                       config.heartbeat_timeout_ms, config.drive_heartbeat_period_ms);
  }
  if (!Positive(config.boot_timeout_ms)) return "boot_timeout_ms must be > 0";
  if (!(config.drive_consumer_timeout_ms >= 0.0) || config.drive_consumer_timeout_ms > 65535.0) {
    return "drive_consumer_timeout_ms must be 0..65535";
  }
  if (config.drive_consumer_timeout_ms > 0.0 &&
      (config.host_node_id == 0 || !(config.drive_consumer_timeout_ms > config.host_heartbeat_period_ms) ||
       config.host_heartbeat_period_ms <= 0.0)) {
    return "drive_consumer_timeout_ms needs a host heartbeat (host_node_id, host_heartbeat_period_ms > 0) faster "
           "than it";
  }
  if (!Positive(config.state_timeout_ms) || !Positive(config.stale_after_ms)) {
    return "state_timeout_ms and stale_after_ms must be > 0";
  }
  return {};
}

/// What is wrong with the scaling, limits, mode and option codes of `config`; empty when nothing.
std::string LimitError(const Cia402DriveConfig& config) {
  const Cia402Scaling& s = config.scaling;
  if (!Positive(s.rated_torque_Nm) || !Positive(s.position_rad_per_count) || !Positive(s.velocity_rad_per_s_per_unit) ||
      (s.sign != 1.0 && s.sign != -1.0)) {
    return "scaling: rated_torque_Nm, position_rad_per_count, velocity_rad_per_s_per_unit must be > 0, sign +1 or -1";
  }
  if (!Positive(config.max_torque_Nm) || config.max_torque_Nm > s.rated_torque_Nm * 32.767) {
    return fmt::format("max_torque_Nm must be in (0, {:g}] (32767 per mille of the rated torque)",
                       s.rated_torque_Nm * 32.767);
  }
  if ((config.sync_cob_id & ~0x7FFu) != 0 || config.sync_cob_id == 0) return "sync_cob_id must be an 11-bit COB-ID";
  const auto mode = static_cast<std::int8_t>(config.mode);
  if (mode != cia402::kModeCyclicSynchronousPosition && mode != cia402::kModeCyclicSynchronousVelocity &&
      mode != cia402::kModeCyclicSynchronousTorque) {
    return fmt::format("mode {} is not a cyclic synchronous mode (8 position, 9 velocity, 10 torque)", mode);
  }
  if (!(config.max_velocity_rad_per_s >= 0.0) || !std::isfinite(config.max_velocity_rad_per_s)) {
    return "max_velocity_rad_per_s must be >= 0 (0: no clamp)";
  }
  if (config.halt_option_code && (*config.halt_option_code < 1 || *config.halt_option_code > 4)) {
    return "halt_option_code must be 1..4";
  }
  return {};
}

}  // namespace

const char* ToString(Cia402Status status) noexcept {
  switch (status) {
    case Cia402Status::kOk:
      return "ok";
    case Cia402Status::kNoNewData:
      return "no_new_data";
    case Cia402Status::kStale:
      return "stale";
    case Cia402Status::kNotEnabled:
      return "not_enabled";
    case Cia402Status::kFault:
      return "fault";
    case Cia402Status::kHeartbeatLost:
      return "heartbeat_lost";
    case Cia402Status::kBusOff:
      return "bus_off";
    case Cia402Status::kWriteFailed:
      return "write_failed";
    case Cia402Status::kNotActive:
      return "not_active";
    case Cia402Status::kWrongMode:
      return "wrong_mode";
  }
  return "invalid";
}

const char* Describe(Cia402Status status) noexcept {
  switch (status) {
    case Cia402Status::kStale:
      return "the drive stopped answering (no TPDO for stale_after_ms)";
    case Cia402Status::kHeartbeatLost:
      return "the drive's heartbeat was lost (heartbeat_timeout_ms)";
    case Cia402Status::kBusOff:
      return "the bus is bus-off";
    case Cia402Status::kWriteFailed:
      return "the port refused a frame (transmit queue full or a bus error)";
    case Cia402Status::kNotEnabled:
      return "the drive left Operation Enabled (an external disable, STO, or a quick stop)";
    case Cia402Status::kFault:
      return "the drive is in Fault";
    case Cia402Status::kWrongMode:
      return "a setpoint of another mode than the configured one";
    case Cia402Status::kNotActive:
      return "the drive is not in the cycle";
    case Cia402Status::kOk:
    case Cia402Status::kNoNewData:
      return "no fault";
  }
  return "an unknown status";
}

std::string DescribeFault(const Cia402DriveConfig& config, Cia402Status status, std::uint16_t emcy_code) {
  std::string text = Describe(status);
  if (status == Cia402Status::kStale) text += fmt::format(", {} ms", config.stale_after_ms);
  if (status == Cia402Status::kHeartbeatLost) text += fmt::format(", {} ms", config.heartbeat_timeout_ms);
  if (status == Cia402Status::kFault && emcy_code != 0) {
    text += fmt::format(": EMCY 0x{:04X} {}", emcy_code, canopen::DescribeEmergencyCode(emcy_code));
  }
  return text;
}

std::vector<PdoMapping> Cia402DriveConfig::DefaultRpdos() {
  return {Mapping(1, {{obj::kControlword, 0, 16}, {obj::kTargetTorque, 0, 16}})};
}

std::vector<PdoMapping> Cia402DriveConfig::DefaultRpdos(Cia402Mode mode) {
  switch (mode) {
    case Cia402Mode::kCyclicSynchronousPosition:
      return {Mapping(1, {{obj::kControlword, 0, 16}, {obj::kTargetPosition, 0, 32}})};
    case Cia402Mode::kCyclicSynchronousVelocity:
      return {Mapping(1, {{obj::kControlword, 0, 16}, {obj::kTargetVelocity, 0, 32}})};
    case Cia402Mode::kCyclicSynchronousTorque:
      break;
  }
  return DefaultRpdos();
}

const char* ToString(Cia402Mode mode) noexcept {
  switch (mode) {
    case Cia402Mode::kCyclicSynchronousPosition:
      return "cyclic synchronous position";
    case Cia402Mode::kCyclicSynchronousVelocity:
      return "cyclic synchronous velocity";
    case Cia402Mode::kCyclicSynchronousTorque:
      return "cyclic synchronous torque";
  }
  return "unknown mode";
}

bool ParseCia402Mode(const std::string& text, Cia402Mode& mode) noexcept {
  if (text == "position" || text == "csp" || text == "8") {
    mode = Cia402Mode::kCyclicSynchronousPosition;
  } else if (text == "velocity" || text == "csv" || text == "9") {
    mode = Cia402Mode::kCyclicSynchronousVelocity;
  } else if (text == "torque" || text == "cst" || text == "10") {
    mode = Cia402Mode::kCyclicSynchronousTorque;
  } else {
    return false;
  }
  return true;
}

std::vector<PdoMapping> Cia402DriveConfig::DefaultTpdos() {
  return {Mapping(1, {{obj::kStatusword, 0, 16}, {obj::kPositionActual, 0, 32}}),
          Mapping(2, {{obj::kVelocityActual, 0, 32}, {obj::kTorqueActual, 0, 16}})};
}

Cia402Drive::Cia402Drive(const Cia402DriveConfig& config, transport::CanPort& port, Timebase timebase)
    : config_(config),
      port_(port),
      timebase_(std::move(timebase)),
      sdo_(port, canopen::IsValidNodeId(config.node_id) ? config.node_id : std::uint8_t{1}, config.sdo,
           Timebase{timebase_.now_ns,
                    [this](std::uint64_t ns) {
                      timebase_.wait_ns(ns);
                      ServiceSetup();
                    }},
           [this](const CanFrame& frame) { HandleFrame(frame); }) {
  const auto fail = [&](const std::string& what) {
    throw Error(fmt::format("CiA 402 drive node {}: {}", config.node_id, what));
  };
  if (const std::string error = TimingError(config); !error.empty()) fail(error);
  if (const std::string error = LimitError(config); !error.empty()) fail(error);
  if (config.mode != Cia402Mode::kCyclicSynchronousTorque &&
      SameMappings(config.rpdos, Cia402DriveConfig::DefaultRpdos())) {
    config_.rpdos = Cia402DriveConfig::DefaultRpdos(config.mode);
  }
  const std::string layout_error =
      Cia402PdoLayout::Make(config_.mode, config_.rpdos, config_.tpdos, config_.node_id, layout_);
  if (!layout_error.empty()) fail(layout_error);
  if (!timebase_.now_ns || !timebase_.wait_ns) fail("timebase without a clock or a wait");
  half_period_ns_ = static_cast<std::uint64_t>(std::llround(config.cycle_period_s * 0.5e9));
}

Cia402Drive::~Cia402Drive() = default;

transport::CanReceiveOptions Cia402Drive::ReceiveOptions(const Cia402DriveConfig& config) {
  transport::CanReceiveOptions o;
  o.filters = {transport::CanFilter::Exact(canopen::cob::kHeartbeat + config.node_id),
               transport::CanFilter::Exact(canopen::cob::kEmcy + config.node_id),
               transport::CanFilter::Exact(canopen::cob::kSdoTx + config.node_id)};
  for (const PdoMapping& m : config.tpdos) {
    o.filters.push_back(transport::CanFilter::Exact(canopen::PdoCobId(m, true, config.node_id)));
  }
  return o;
}

void Cia402Drive::SetDriveState(DriveState state) noexcept {
  if (state != drive_state_) {
    ++counters_.state_changes;
    drive_state_ = state;
  }
}

void Cia402Drive::HandleFrame(const CanFrame& frame) noexcept {
  if (frame.error) {
    ++counters_.error_frames;
    if ((frame.error_class & proto::can::kErrBusOff) != 0) {
      ++counters_.bus_off;
      bus_off_ = true;
    }
    if ((frame.error_class & proto::can::kErrRestarted) != 0) bus_off_ = false;
    return;
  }
  const std::uint64_t now = timebase_.now_ns();
  std::uint8_t node = 0;
  NmtState state{};
  if (canopen::DecodeHeartbeat(frame, node, state) && node == config_.node_id) {
    ++counters_.heartbeats_received;
    heartbeat_seen_ = true;
    last_heartbeat_ns_ = now;
    nmt_state_ = state;
    if (state == NmtState::kBootUp) boot_seen_ = true;
    return;
  }
  canopen::Emergency emergency{};
  if (canopen::DecodeEmergency(frame, node, emergency) && node == config_.node_id) {
    ++counters_.emergencies;
    last_emergency_ = emergency;
    if (emergency.error_code != canopen::emcy::kNoError && active_) fault_latched_ = true;
    return;
  }
  int pdo = -1;
  switch (cia402_codec::DecodeTpdo(layout_, frame, tpdo_values_, pdo)) {
    case Cia402TpdoResult::kRejected:
      ++counters_.tpdos_rejected;
      return;
    case Cia402TpdoResult::kStored:
      ++counters_.tpdos_received;
      tpdo_stamp_ns_[static_cast<std::size_t>(pdo)] = now;
      tpdo_seen_mask_ |= 1u << pdo;
      if (layout_.statusword.pdo == pdo) {
        statusword_ = cia402_codec::Statusword(layout_, tpdo_values_);
        SetDriveState(cia402::DecodeStatusword(statusword_));
      }
      return;
    case Cia402TpdoResult::kNotTpdo:
      break;
  }
  ++counters_.other_frames;
}

bool Cia402Drive::SendHeartbeatIfDue(std::uint64_t now_ns) noexcept {
  if (config_.host_node_id == 0 || config_.host_heartbeat_period_ms <= 0.0 || now_ns < next_host_heartbeat_ns_) {
    return true;
  }
  next_host_heartbeat_ns_ = now_ns + MsToNs(config_.host_heartbeat_period_ms);
  if (port_.Write(canopen::EncodeHeartbeat(config_.host_node_id, NmtState::kOperational)) !=
      transport::CanWriteStatus::kOk) {
    ++counters_.write_failures;
    return false;
  }
  ++counters_.heartbeats_sent;
  return true;
}

void Cia402Drive::ServiceSetup() noexcept { (void)SendHeartbeatIfDue(timebase_.now_ns()); }

bool Cia402Drive::HeartbeatExpired(std::uint64_t now_ns) noexcept {
  if (config_.drive_heartbeat_period_ms <= 0.0 || !heartbeat_seen_) return heartbeat_lost_;
  if (!heartbeat_lost_ && now_ns > last_heartbeat_ns_ + MsToNs(config_.heartbeat_timeout_ms)) {
    heartbeat_lost_ = true;
    ++counters_.heartbeat_timeouts;
  }
  return heartbeat_lost_;
}

Cia402Status Cia402Drive::Read(Cia402Reading& reading) noexcept {
  CanFrame frame{};
  for (int i = 0; i < kMaxFramesPerRead && port_.Read(frame); ++i) HandleFrame(frame);
  if (!active_) return Cia402Status::kNotActive;
  const std::uint64_t now = timebase_.now_ns();
  const unsigned all = (1u << layout_.tpdo_count) - 1u;
  const bool fresh = (tpdo_seen_mask_ & all) == all;
  if (fresh) {
    tpdo_seen_mask_ = 0;
    const Cia402Measured m = cia402_codec::Measured(layout_, tpdo_values_, config_.scaling);
    newest_.position_rad = m.position_rad;
    newest_.velocity_rad_per_s = m.velocity_rad_per_s;
    newest_.torque_Nm = m.torque_mapped ? m.torque_Nm : commanded_torque_Nm_;
    newest_.stamp_ns = 0;
    for (int p = 0; p < layout_.tpdo_count; ++p) {
      newest_.stamp_ns = std::max(newest_.stamp_ns, tpdo_stamp_ns_[static_cast<std::size_t>(p)]);
    }
  }
  newest_.statusword = statusword_;
  newest_.state = drive_state_;
  newest_.fresh = fresh;
  reading = newest_;
  std::uint64_t oldest = now;
  for (int p = 0; p < layout_.tpdo_count; ++p) oldest = std::min(oldest, tpdo_stamp_ns_[static_cast<std::size_t>(p)]);
  if (bus_off_) return Cia402Status::kBusOff;
  if (HeartbeatExpired(now)) return Cia402Status::kHeartbeatLost;
  if (fault_latched_ || drive_state_ == DriveState::kFault || drive_state_ == DriveState::kFaultReactionActive) {
    return Cia402Status::kFault;
  }
  if (now > oldest + MsToNs(config_.stale_after_ms)) return Cia402Status::kStale;
  if (drive_state_ != DriveState::kOperationEnabled) return Cia402Status::kNotEnabled;
  return fresh ? Cia402Status::kOk : Cia402Status::kNoNewData;
}

Cia402Status Cia402Drive::WriteTorque_Nm(double torque_Nm) noexcept {
  if (config_.mode != Cia402Mode::kCyclicSynchronousTorque) return WrongMode();
  return Transmit(TorqueTarget(torque_Nm));
}

Cia402Status Cia402Drive::WriteVelocity_rad_per_s(double velocity_rad_per_s) noexcept {
  if (config_.mode != Cia402Mode::kCyclicSynchronousVelocity) return WrongMode();
  return Transmit(VelocityTarget(velocity_rad_per_s));
}

Cia402Status Cia402Drive::WritePosition_rad(double position_rad) noexcept {
  if (config_.mode != Cia402Mode::kCyclicSynchronousPosition) return WrongMode();
  return Transmit(PositionTarget(position_rad));
}

Cia402Status Cia402Drive::WriteHold() noexcept {
  switch (config_.mode) {
    case Cia402Mode::kCyclicSynchronousTorque:
      return Transmit(TorqueTarget(0.0));
    case Cia402Mode::kCyclicSynchronousVelocity:
      return Transmit(VelocityTarget(0.0));
    case Cia402Mode::kCyclicSynchronousPosition:
      break;
  }
  return Transmit(PositionTarget(position_target_rad_));
}

Cia402Status Cia402Drive::WrongMode() noexcept {
  ++counters_.wrong_mode_setpoints;
  const Cia402Status status = WriteHold();
  return status == Cia402Status::kOk ? Cia402Status::kWrongMode : status;
}

bool Cia402Drive::HoldTargets() const noexcept {
  return quick_stop_requested_ || fault_latched_ || heartbeat_lost_ || bus_off_;
}

std::uint32_t Cia402Drive::TorqueTarget(double torque_Nm) noexcept {
  if (!std::isfinite(torque_Nm)) {
    ++counters_.non_finite_commands;
    torque_Nm = 0.0;
  }
  if (std::abs(torque_Nm) > config_.max_torque_Nm) {
    ++counters_.torque_clamped;
    torque_Nm = std::clamp(torque_Nm, -config_.max_torque_Nm, config_.max_torque_Nm);
  }
  if (HoldTargets()) torque_Nm = 0.0;
  pending_torque_Nm_ = torque_Nm;
  return static_cast<std::uint16_t>(cia402_codec::TorqueToPerMille(torque_Nm, config_.scaling));
}

std::uint32_t Cia402Drive::VelocityTarget(double velocity_rad_per_s) noexcept {
  if (!std::isfinite(velocity_rad_per_s)) {
    ++counters_.non_finite_commands;
    velocity_rad_per_s = 0.0;
  }
  const double limit = config_.max_velocity_rad_per_s;
  if (limit > 0.0 && std::abs(velocity_rad_per_s) > limit) {
    ++counters_.velocity_clamped;
    velocity_rad_per_s = std::clamp(velocity_rad_per_s, -limit, limit);
  }
  if (HoldTargets()) velocity_rad_per_s = 0.0;
  return static_cast<std::uint32_t>(cia402_codec::VelocityToUnits(velocity_rad_per_s, config_.scaling));
}

std::uint32_t Cia402Drive::PositionTarget(double position_rad) noexcept {
  if (!std::isfinite(position_rad)) {
    ++counters_.non_finite_commands;
    position_rad = position_target_rad_;
  }
  if (HoldTargets()) position_rad = position_target_rad_;
  // The step from the target of the last SYNC (a skipped Write keeps nothing): at most the limit per SYNC.
  const double step = config_.max_velocity_rad_per_s * config_.cycle_period_s;
  if (step > 0.0 && std::abs(position_rad - position_target_rad_) > step) {
    ++counters_.position_step_clamped;
    position_rad = std::clamp(position_rad, position_target_rad_ - step, position_target_rad_ + step);
  }
  pending_position_rad_ = position_rad;
  return static_cast<std::uint32_t>(cia402_codec::PositionToCounts(position_rad, config_.scaling));
}

Cia402Status Cia402Drive::Transmit(std::uint32_t target_raw) noexcept {
  if (!active_) return Cia402Status::kNotActive;
  const std::uint64_t now = timebase_.now_ns();
  Cia402Status status = Cia402Status::kOk;
  // No burst of SYNCs (a late loop catching up): within half a period of the last SYNC nothing is sent, so the
  // target of the last SYNC stays the reference of the position step.
  const bool early = config_.produce_sync && sync_sent_ && now < last_sync_ns_ + half_period_ns_;
  if (early) {
    ++counters_.syncs_skipped;
  } else {
    controlword_ = quick_stop_requested_ ? cia402::cw::kCmdQuickStop : cia402::cw::kCmdEnableOperation;
    if (halt_requested_) controlword_ |= cia402::cw::kHalt;
    if (config_.mode == Cia402Mode::kCyclicSynchronousTorque) commanded_torque_Nm_ = pending_torque_Nm_;
    if (config_.mode == Cia402Mode::kCyclicSynchronousPosition) position_target_rad_ = pending_position_rad_;
    if (!SendRpdos(target_raw)) status = Cia402Status::kWriteFailed;
    if (config_.produce_sync && !SendSync(now)) status = Cia402Status::kWriteFailed;
  }
  if (!SendHeartbeatIfDue(now)) status = Cia402Status::kWriteFailed;
  if (bus_off_) return Cia402Status::kBusOff;
  if (heartbeat_lost_) return Cia402Status::kHeartbeatLost;
  if (fault_latched_) return Cia402Status::kFault;
  return status;
}

bool Cia402Drive::SendRpdos(std::uint32_t target_raw) noexcept {
  std::array<CanFrame, 4> frames{};
  if (!cia402_codec::EncodeRpdos(layout_, controlword_, target_raw, frames)) {
    ++counters_.write_failures;
    return false;
  }
  bool ok = true;
  for (int p = 0; p < layout_.rpdo_count; ++p) {
    if (port_.Write(frames[static_cast<std::size_t>(p)]) != transport::CanWriteStatus::kOk) {
      ++counters_.write_failures;
      ok = false;
      continue;
    }
    ++counters_.rpdos_sent;
  }
  return ok;
}

bool Cia402Drive::SendSync(std::uint64_t now_ns) noexcept {
  if (port_.Write(canopen::EncodeSync(config_.sync_cob_id)) != transport::CanWriteStatus::kOk) {
    ++counters_.write_failures;
    return false;
  }
  ++counters_.syncs_sent;
  sync_sent_ = true;
  last_sync_ns_ = now_ns;
  return true;
}

void Cia402Drive::RequestQuickStop() noexcept { quick_stop_requested_ = true; }

std::string Cia402Drive::Describe() const {
  std::string text = fmt::format("CiA 402 node {} on {}: RPDO", config_.node_id, port_.Describe());
  for (int p = 0; p < layout_.rpdo_count; ++p) {
    text += fmt::format(" 0x{:03X}", layout_.rpdo_cob[static_cast<std::size_t>(p)]);
  }
  text += ", TPDO";
  for (int p = 0; p < layout_.tpdo_count; ++p) {
    text += fmt::format(" 0x{:03X}", layout_.tpdo_cob[static_cast<std::size_t>(p)]);
  }
  text += fmt::format(", SYNC 0x{:03X} {} every {:g} ms, heartbeat {:g} ms (timeout {:g} ms)", config_.sync_cob_id,
                      config_.produce_sync ? "produced" : "not produced", config_.cycle_period_s * 1e3,
                      config_.drive_heartbeat_period_ms, config_.heartbeat_timeout_ms);
  return text;
}

}  // namespace teleop::fieldbus
