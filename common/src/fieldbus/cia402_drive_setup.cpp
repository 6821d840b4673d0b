// Cia402Drive's set-up (docs/cia402.md): NMT reset and boot-up, the identity and EDS checks, the communication
// objects, the PDO mapping written and read back, the mode, the limits (Configure, one step per function); the state
// machine to Operation Enabled by SDO (Activate); the safe state (Deactivate). Blocking, may throw teleop::Error;
// never called from the cycle (cia402_drive.cpp).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <utility>

#include "teleop/error.hpp"
#include "teleop/fieldbus/canopen_heartbeat_producer.hpp"
#include "teleop/fieldbus/cia402_drive.hpp"
#include "teleop/fieldbus/cia402_eds.hpp"

namespace teleop::fieldbus {

using canopen::NmtCommand;
using canopen::PdoMapping;
using cia402::DriveState;
using proto::can::CanFrame;
namespace obj = cia402::obj;
namespace obj301 = cia402::obj301;

namespace {

/// Poll step of the set-up waits.
constexpr std::uint64_t kSetupPoll_ns = 500'000;

/// An abort that says the object is simply not there (CiA 301: no object, no subindex, unsupported access,
/// write-only, no data): an optional object the drive lacks.
bool IsAbsent(std::uint32_t code) noexcept {
  namespace a = canopen::sdo_abort;
  return code == a::kNoObject || code == a::kNoSubindex || code == a::kUnsupportedAccess || code == a::kWriteOnly ||
         code == a::kNoData;
}

/// Runs `read`; an abort for a missing object leaves `present` false, any other error propagates.
template <typename F>
void ReadOptional(bool& present, F&& read) {
  try {
    read();
    present = true;
  } catch (const canopen::SdoAbortError& e) {
    if (!IsAbsent(e.code())) throw;
    present = false;
  }
}

/// Runs `write` to an object CiA 301 makes optional; an abort saying the object or sub-index does not exist leaves
/// `present` false (a read-only or refused value is still an error).
template <typename F>
void WriteOptional(bool& present, F&& write) {
  try {
    write();
    present = true;
  } catch (const canopen::SdoAbortError& e) {
    if (e.code() != canopen::sdo_abort::kNoObject && e.code() != canopen::sdo_abort::kNoSubindex) throw;
    present = false;
  }
}

}  // namespace

void Cia402Drive::WaitForBoot() {
  const std::uint64_t start = timebase_.now_ns();
  const std::uint64_t deadline = start + MsToNs(config_.boot_timeout_ms);
  for (;;) {
    CanFrame frame{};
    while (port_.Read(frame)) HandleFrame(frame);
    if (boot_seen_) return;
    const std::uint64_t now = timebase_.now_ns();
    if (now >= deadline) break;
    (void)SendHeartbeatIfDue(now);
    timebase_.wait_ns(kSetupPoll_ns);
  }
  throw Error(fmt::format(
      "CiA 402 drive node {}: no boot-up message (0x{:03X}#00) within boot_timeout_ms {:g} ms after NMT {} — is "
      "the drive powered, on this bus, with node-ID {}, at this bit rate?",
      config_.node_id, canopen::cob::kHeartbeat + config_.node_id, config_.boot_timeout_ms,
      config_.reset_node ? "reset node" : "reset communication", config_.node_id));
}

void Cia402Drive::WritePdo(const PdoMapping& m, bool tpdo) {
  const auto n = static_cast<std::uint16_t>(m.number - 1);
  const auto comm = static_cast<std::uint16_t>((tpdo ? obj301::kTpdoCommunication : obj301::kRpdoCommunication) + n);
  const auto map = static_cast<std::uint16_t>((tpdo ? obj301::kTpdoMapping : obj301::kRpdoMapping) + n);
  const std::uint32_t cob = canopen::PdoCobId(m, tpdo, config_.node_id);
  // CiA 301 PDO mapping procedure: invalidate the PDO, clear the count, write the entries, set the count, make it
  // valid.
  // Bit 30 set: no RTR (the client never requests a PDO; a device without RTR may refuse 0, CiA 301 lets it).
  const std::uint32_t cob_entry = cob | canopen::cob::kNoRtrBit;
  sdo_.Download(comm, 1, cob_entry | canopen::cob::kInvalidBit, 4);
  sdo_.Download(map, 0, 0, 1);
  for (int k = 0; k < m.entry_count; ++k) {
    sdo_.Download(map, static_cast<std::uint8_t>(k + 1), m.entries[static_cast<std::size_t>(k)].MappingValue(), 4);
  }
  sdo_.Download(map, 0, static_cast<std::uint32_t>(m.entry_count), 1);
  sdo_.Download(comm, 2, m.transmission_type, 1);
  sdo_.Download(comm, 1, cob_entry, 4);
  // Read it back (field notes: factory mappings of the wrong length break decoding).
  const auto what = [&](const std::string& detail) {
    return Error(fmt::format("CiA 402 drive node {}: {}PDO{} read back differs from what was written: {}",
                             config_.node_id, tpdo ? "T" : "R", m.number, detail));
  };
  const std::uint32_t count = sdo_.Upload(map, 0, 1);
  if (count != static_cast<std::uint32_t>(m.entry_count)) {
    throw what(fmt::format("{} entries instead of {}", count, m.entry_count));
  }
  for (int k = 0; k < m.entry_count; ++k) {
    const std::uint32_t entry = sdo_.Upload(map, static_cast<std::uint8_t>(k + 1), 4);
    const std::uint32_t want = m.entries[static_cast<std::size_t>(k)].MappingValue();
    if (entry != want) throw what(fmt::format("entry {} is 0x{:08X}, not 0x{:08X}", k + 1, entry, want));
  }
  const std::uint32_t cob_back = sdo_.Upload(comm, 1, 4);
  if ((cob_back & canopen::cob::kInvalidBit) != 0 || (cob_back & 0x7FFu) != cob) {
    throw what(fmt::format("COB-ID 0x{:08X}, not 0x{:03X} valid", cob_back, cob));
  }
  const std::uint32_t type = sdo_.Upload(comm, 2, 1);
  if (type != m.transmission_type) throw what(fmt::format("transmission type {}, not {}", type, m.transmission_type));
}

std::string Cia402DeviceInfo::Describe() const {
  std::string s = fmt::format("device type 0x{:08X}", device_type);
  if (identity_present) {
    s += fmt::format("; identity: vendor 0x{:08X}, product 0x{:08X}, revision 0x{:08X}, serial 0x{:08X}", vendor_id,
                     product_code, revision, serial);
  }
  s += device_name_present ? fmt::format("; device name '{}'", device_name) : std::string("; no device name");
  if (hardware_version_present) s += fmt::format("; hardware '{}'", hardware_version);
  if (software_version_present) s += fmt::format("; software '{}'", software_version);
  if (supported_modes_present) s += fmt::format("; supported modes 0x{:08X}", supported_modes);
  if (!error_history_present) {
    s += "; no error history";
  } else if (error_history.empty()) {
    s += "; error history empty";
  } else {
    s += "; error history (newest first):";
    for (const std::uint32_t e : error_history) s += fmt::format(" 0x{:04X}/0x{:04X}", e & 0xFFFFu, e >> 16);
  }
  return s;
}

const Cia402DeviceInfo& Cia402Drive::ReadDeviceInfo() {
  Cia402DeviceInfo info;
  info.device_type = sdo_.Upload(obj301::kDeviceType, 0, 4);
  ReadOptional(info.identity_present, [&] {
    const std::uint32_t count = sdo_.Upload(obj301::kIdentity, 0, 1);
    info.vendor_id = sdo_.Upload(obj301::kIdentity, 1, 4);
    if (count >= 2) info.product_code = sdo_.Upload(obj301::kIdentity, 2, 4);
    if (count >= 3) info.revision = sdo_.Upload(obj301::kIdentity, 3, 4);
    if (count >= 4) info.serial = sdo_.Upload(obj301::kIdentity, 4, 4);
  });
  ReadOptional(info.device_name_present, [&] { info.device_name = sdo_.UploadString(obj301::kDeviceName, 0, 256); });
  ReadOptional(info.hardware_version_present,
               [&] { info.hardware_version = sdo_.UploadString(obj301::kHardwareVersion, 0, 256); });
  ReadOptional(info.software_version_present,
               [&] { info.software_version = sdo_.UploadString(obj301::kSoftwareVersion, 0, 256); });
  ReadOptional(info.supported_modes_present,
               [&] { info.supported_modes = sdo_.Upload(obj::kSupportedDriveModes, 0, 4); });
  ReadOptional(info.error_history_present, [&] {
    const std::uint32_t count = sdo_.Upload(obj301::kErrorHistory, 0, 1);
    for (std::uint32_t sub = 1; sub <= std::min<std::uint32_t>(count, 254); ++sub) {
      info.error_history.push_back(sdo_.Upload(obj301::kErrorHistory, static_cast<std::uint8_t>(sub), 4));
    }
  });
  info_ = std::move(info);
  return info_;
}

void Cia402Drive::Configure() {
  active_ = false;
  configured_ = false;
  boot_seen_ = false;
  heartbeat_seen_ = false;
  heartbeat_lost_ = false;
  fault_latched_ = false;
  bus_off_ = false;
  last_emergency_ = canopen::Emergency{};
  last_error_.clear();
  const std::string where = ConfigureWhere();
  bool consumer_armed = false;  // 0x1016:01 written non-zero: undone if anything after it fails
  try {
    CheckEds();  // before any bus traffic: a drive whose EDS does not fit is never touched
    ResetAndWaitForBoot();
    CheckIdentity();
    WriteCommunicationObjects(consumer_armed);
    WritePdos();
    SelectMode();
    WriteLimits();
    WriteHoldTarget();
    configured_ = true;
  } catch (const Error& e) {
    last_error_ = e.what();
    if (last_error_.rfind("CiA 402", 0) != 0) last_error_ = where + ": " + last_error_;
    // Half a configure is undone (docs/cia402.md): an armed consumer would fire when a later session's heartbeats
    // stop. A drive that no longer answers keeps it; the error says why configure failed, not this.
    if (consumer_armed) {
      try {
        sdo_.Download(obj301::kConsumerHeartbeatTime, 1, 0, 4);
      } catch (const Error& undo) {
        last_error_ += fmt::format("; switching the heartbeat consumer 0x1016:01 off again failed: {}", undo.what());
      }
    }
    throw Error(last_error_);
  }
}

std::string Cia402Drive::ConfigureWhere() const {
  return fmt::format("CiA 402 drive node {}: configure", config_.node_id);
}

void Cia402Drive::CheckEds() const {
  const std::string where = ConfigureWhere();
  if (!config_.eds_file.empty()) {  // before any bus traffic: a drive whose EDS does not fit is never touched
    const std::vector<std::string> problems = CheckAgainstEds(canopen::Eds::Load(config_.eds_file), config_);
    if (!problems.empty()) {
      std::string text = fmt::format("{}: the EDS does not fit the configuration:", where);
      for (const std::string& p : problems) text += "\n  " + p;
      throw Error(text);
    }
  }
}

void Cia402Drive::ResetAndWaitForBoot() {
  const std::string where = ConfigureWhere();
  CanFrame frame{};
  while (port_.Read(frame)) HandleFrame(frame);  // whatever came before is not this bring-up's
  boot_seen_ = false;
  const NmtCommand reset = config_.reset_node ? NmtCommand::kResetNode : NmtCommand::kResetCommunication;
  if (port_.Write(canopen::EncodeNmt(reset, config_.node_id)) != transport::CanWriteStatus::kOk) {
    throw Error(where + ": the CAN port refused the NMT command");
  }
  WaitForBoot();
}

void Cia402Drive::CheckIdentity() {
  const std::string where = ConfigureWhere();
  // The identity, name, versions and error history first (logged, so a refusal below names the drive).
  if (config_.read_device_info) {
    spdlog::info("CiA 402 drive node {}: {}", config_.node_id, ReadDeviceInfo().Describe());
  }
  const std::uint32_t device_type =
      config_.read_device_info ? info_.device_type : sdo_.Upload(obj301::kDeviceType, 0, 4);
  if ((device_type & 0xFFFFu) != cia402::kDeviceProfile402) {
    throw Error(fmt::format("{}: device type 0x{:08X} is not a CiA 402 drive (profile 0x{:04X}, expected 0x0192)",
                            where, device_type, device_type & 0xFFFFu));
  }
  const auto mode = static_cast<std::int8_t>(config_.mode);
  const bool torque_mode = config_.mode == Cia402Mode::kCyclicSynchronousTorque;
  const std::uint32_t modes = config_.read_device_info && info_.supported_modes_present
                                  ? info_.supported_modes
                                  : sdo_.Upload(obj::kSupportedDriveModes, 0, 4);
  if ((modes & cia402::SupportedModeBit(mode)) == 0) {
    throw Error(fmt::format("{}: the drive does not support {} (0x6502 = 0x{:08X}, bit {} clear)", where,
                            ToString(config_.mode), modes, mode - 1));
  }
  // The rated torque scales 0x6071/0x6072/0x6077: required in torque mode, checked when present otherwise.
  std::uint32_t rated_mNm = 0;
  bool rated_present = true;
  if (torque_mode) {
    rated_mNm = sdo_.Upload(obj::kRatedTorque, 0, 4);
  } else {
    ReadOptional(rated_present, [&] { rated_mNm = sdo_.Upload(obj::kRatedTorque, 0, 4); });
  }
  const double rated_Nm = rated_mNm * 1e-3;
  if (rated_present &&
      std::abs(rated_Nm - config_.scaling.rated_torque_Nm) > 1e-3 + 1e-3 * config_.scaling.rated_torque_Nm) {
    throw Error(
        fmt::format("{}: the drive's rated torque 0x6076 is {:g} N·m, the configuration says {:g} N·m "
                    "(scaling.rated_torque_Nm)",
                    where, rated_Nm, config_.scaling.rated_torque_Nm));
  }
}

void Cia402Drive::WriteCommunicationObjects(bool& consumer_armed) {
  // Heartbeats: the drive's producer, and its consumer of the host.
  sdo_.Download(obj301::kProducerHeartbeatTime, 0,
                static_cast<std::uint32_t>(std::lround(config_.drive_heartbeat_period_ms)), 2);
  const std::uint32_t consumer =
      config_.drive_consumer_timeout_ms > 0.0
          ? canopen::ConsumerHeartbeatEntry(config_.host_node_id,
                                            static_cast<std::uint16_t>(std::lround(config_.drive_consumer_timeout_ms)))
          : 0u;
  // The consumer heartbeat 0x1016 and the cycle period 0x1006 are optional in CiA 301 (0x1006 is mandatory only
  // for a SYNC producer, which the drive is not): a drive without them is fine unless a consumer is asked for.
  bool present = true;
  if (consumer != 0) {
    sdo_.Download(obj301::kConsumerHeartbeatTime, 1, consumer, 4);
    consumer_armed = true;
  } else {
    WriteOptional(present, [&] { sdo_.Download(obj301::kConsumerHeartbeatTime, 1, 0, 4); });
  }
  sdo_.Download(obj301::kCobIdSync, 0, config_.sync_cob_id, 4);
  WriteOptional(present, [&] {
    sdo_.Download(obj301::kCommunicationCyclePeriod, 0,
                  static_cast<std::uint32_t>(std::llround(config_.cycle_period_s * 1e6)), 4);
  });
}

void Cia402Drive::WritePdos() {
  bool present = true;
  // PDOs: the configured ones written and read back, the others switched off.
  for (int n = 1; n <= 4; ++n) {
    bool rpdo_used = false;
    bool tpdo_used = false;
    for (int p = 0; p < layout_.rpdo_count; ++p) {
      if (layout_.rpdo[static_cast<std::size_t>(p)].number == n) {
        WritePdo(layout_.rpdo[static_cast<std::size_t>(p)], false);
        rpdo_used = true;
      }
    }
    for (int p = 0; p < layout_.tpdo_count; ++p) {
      if (layout_.tpdo[static_cast<std::size_t>(p)].number == n) {
        WritePdo(layout_.tpdo[static_cast<std::size_t>(p)], true);
        tpdo_used = true;
      }
    }
    // A drive with fewer than four PDOs of a kind (CiA 301 asks for none) has nothing to switch off there.
    if (!rpdo_used) {
      WriteOptional(present, [&] {
        sdo_.Download(
            static_cast<std::uint16_t>(obj301::kRpdoCommunication + n - 1), 1,
            canopen::cob::kInvalidBit | canopen::cob::kNoRtrBit | canopen::cob::DefaultRpdo(n, config_.node_id), 4);
      });
    }
    if (!tpdo_used) {
      WriteOptional(present, [&] {
        sdo_.Download(
            static_cast<std::uint16_t>(obj301::kTpdoCommunication + n - 1), 1,
            canopen::cob::kInvalidBit | canopen::cob::kNoRtrBit | canopen::cob::DefaultTpdo(n, config_.node_id), 4);
      });
    }
  }
}

void Cia402Drive::SelectMode() {
  const std::string where = ConfigureWhere();
  const auto mode = static_cast<std::int8_t>(config_.mode);
  sdo_.Download(obj::kModesOfOperation, 0, static_cast<std::uint8_t>(mode), 1);
  // A drive switches modes in its own cycle: 0x6061 may show the old mode for a while (polled up to
  // state_timeout_ms).
  const std::uint64_t mode_deadline = timebase_.now_ns() + MsToNs(config_.state_timeout_ms);
  auto display = static_cast<std::int8_t>(sdo_.Upload(obj::kModesOfOperationDisplay, 0, 1));
  while (display != mode && timebase_.now_ns() < mode_deadline) {
    timebase_.wait_ns(kSetupPoll_ns);
    display = static_cast<std::int8_t>(sdo_.Upload(obj::kModesOfOperationDisplay, 0, 1));
  }
  if (display != mode) {
    throw Error(fmt::format("{}: modes of operation display 0x6061 is {} {:g} ms after writing {} to 0x6060", where,
                            display, config_.state_timeout_ms, mode));
  }
}

void Cia402Drive::WriteLimits() {
  bool present = true;
  const bool torque_mode = config_.mode == Cia402Mode::kCyclicSynchronousTorque;
  const auto max_torque =
      static_cast<std::uint32_t>(std::lround(config_.max_torque_Nm / config_.scaling.rated_torque_Nm * 1000.0));
  if (torque_mode) {
    sdo_.Download(obj::kMaxTorque, 0, max_torque, 2);
  } else {  // the torque limit of the drive's loops, where it has one
    present = false;
    ReadOptional(present, [&] { sdo_.Download(obj::kMaxTorque, 0, max_torque, 2); });
  }
  if (config_.quick_stop_option_code) {
    sdo_.Download(obj::kQuickStopOptionCode, 0, static_cast<std::uint16_t>(*config_.quick_stop_option_code), 2);
  }
  if (config_.fault_reaction_option_code) {
    sdo_.Download(obj::kFaultReactionOptionCode, 0, static_cast<std::uint16_t>(*config_.fault_reaction_option_code), 2);
  }
  if (config_.halt_option_code) {
    sdo_.Download(obj::kHaltOptionCode, 0, static_cast<std::uint16_t>(*config_.halt_option_code), 2);
  }
}

void Cia402Drive::Activate() {
  const std::string where = fmt::format("CiA 402 drive node {}: activate", config_.node_id);
  if (!configured_) throw Error(where + ": Configure() first");
  try {
    heartbeat_lost_ = false;
    fault_latched_ = false;
    quick_stop_requested_ = false;
    // Operational (again, after a Deactivate): PDOs flow only in NMT Operational.
    if (port_.Write(canopen::EncodeNmt(NmtCommand::kStart, config_.node_id)) != transport::CanWriteStatus::kOk) {
      throw Error(where + ": the CAN port refused NMT start");
    }
    WriteHoldTarget();
    DriveState state = DriveState::kUnknown;
    std::uint16_t sent = controlword_;
    std::string fault_text;
    // At most one reset and the four steps Switch On Disabled → Operation Enabled, each within state_timeout_ms.
    for (int step = 0; step < 8; ++step) {
      std::uint16_t statusword = static_cast<std::uint16_t>(sdo_.Upload(obj::kStatusword, 0, 2));
      state = cia402::DecodeStatusword(statusword);
      SetDriveState(state);
      if (state == DriveState::kOperationEnabled) break;
      if (state == DriveState::kFault && fault_text.empty()) {
        const auto code = static_cast<std::uint16_t>(sdo_.Upload(obj::kErrorCode, 0, 2));
        const auto reg = static_cast<std::uint8_t>(sdo_.Upload(obj301::kErrorRegister, 0, 1));
        fault_text = fmt::format("error code 0x{:04X} ({}), error register 0x{:02X}", code,
                                 canopen::DescribeEmergencyCode(code), reg);
      }
      std::uint16_t command = cia402::ControlwordTowardOperationEnabled(state, sent);
      if (state == DriveState::kFault && command == 0) {  // bit 7 low first, so that the reset rises
        sdo_.Download(obj::kControlword, 0, 0, 2);
        command = cia402::cw::kCmdFaultReset;
      }
      sdo_.Download(obj::kControlword, 0, command, 2);
      sent = command;
      controlword_ = command;
      // Wait for the state to change.
      const std::uint64_t deadline = timebase_.now_ns() + MsToNs(config_.state_timeout_ms);
      DriveState now_state = state;
      while (now_state == state) {
        if (timebase_.now_ns() >= deadline) {
          throw Error(
              fmt::format("{}: the drive stayed in {} after controlword 0x{:04X} for state_timeout_ms {:g} ms{}", where,
                          cia402::ToString(state), command, config_.state_timeout_ms,
                          fault_text.empty() ? std::string() : "; " + fault_text));
        }
        timebase_.wait_ns(MsToNs(std::min(1.0, config_.cycle_period_s * 1e3)));
        ServiceSetup();
        statusword = static_cast<std::uint16_t>(sdo_.Upload(obj::kStatusword, 0, 2));
        now_state = cia402::DecodeStatusword(statusword);
      }
      SetDriveState(now_state);
    }
    if (state != DriveState::kOperationEnabled) {
      throw Error(fmt::format("{}: did not reach Operation Enabled (last state {}){}", where, cia402::ToString(state),
                              fault_text.empty() ? std::string() : "; " + fault_text));
    }
    controlword_ = cia402::cw::kCmdEnableOperation;
    const std::uint64_t now = timebase_.now_ns();
    for (int p = 0; p < layout_.tpdo_count; ++p) tpdo_stamp_ns_[static_cast<std::size_t>(p)] = now;
    tpdo_seen_mask_ = 0;
    fault_latched_ = false;
    sync_sent_ = false;
    active_ = true;
  } catch (const Error& e) {
    last_error_ = e.what();
    if (last_error_.rfind("CiA 402", 0) != 0) last_error_ = where + ": " + last_error_;
    throw Error(last_error_);
  }
}

bool Cia402Drive::Deactivate() noexcept {
  active_ = false;
  try {
    if (config_.mode != Cia402Mode::kCyclicSynchronousPosition) WriteHoldTarget();
    const DriveState state = cia402::DecodeStatusword(static_cast<std::uint16_t>(sdo_.Upload(obj::kStatusword, 0, 2)));
    if (state == DriveState::kOperationEnabled) {
      sdo_.Download(obj::kControlword, 0, cia402::cw::kCmdSwitchOn, 2);  // 5: disable operation
    } else if (state == DriveState::kQuickStopActive) {
      // Shutdown is no transition out of Quick Stop Active (0x605A 5..8 holds there): Disable Voltage is (12).
      sdo_.Download(obj::kControlword, 0, cia402::cw::kCmdDisableVoltage, 2);
    }
    sdo_.Download(obj::kControlword, 0, cia402::cw::kCmdShutdown, 2);  // 6/8: to Ready To Switch On
    controlword_ = cia402::cw::kCmdShutdown;
    SetDriveState(cia402::DecodeStatusword(static_cast<std::uint16_t>(sdo_.Upload(obj::kStatusword, 0, 2))));
    (void)port_.Write(canopen::EncodeNmt(NmtCommand::kEnterPreOperational, config_.node_id));
    return drive_state_ != DriveState::kOperationEnabled;
  } catch (const std::exception& e) {
    last_error_ = fmt::format("CiA 402 drive node {}: deactivate: {}", config_.node_id, e.what());
    (void)port_.Write(canopen::EncodeNmt(NmtCommand::kEnterPreOperational, config_.node_id));
    return false;
  }
}

void Cia402Drive::WriteHoldTarget() {
  switch (config_.mode) {
    case Cia402Mode::kCyclicSynchronousTorque:
      sdo_.Download(obj::kTargetTorque, 0, 0, 2);
      return;
    case Cia402Mode::kCyclicSynchronousVelocity:
      sdo_.Download(obj::kTargetVelocity, 0, 0, 4);
      return;
    case Cia402Mode::kCyclicSynchronousPosition: {
      // The target where the joint is: enabling must not make it jump.
      const std::uint32_t actual = sdo_.Upload(obj::kPositionActual, 0, 4);
      sdo_.Download(obj::kTargetPosition, 0, actual, 4);
      position_target_rad_ = config_.scaling.sign * config_.scaling.position_rad_per_count *
                             static_cast<double>(static_cast<std::int32_t>(actual));
      return;
    }
  }
}

std::uint8_t Cia402Drive::ReadErrorRegister() {
  return static_cast<std::uint8_t>(sdo_.Upload(obj301::kErrorRegister, 0, 1));
}

}  // namespace teleop::fieldbus
