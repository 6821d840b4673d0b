#include "teleop/fieldbus/cia402_drive.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <utility>

#include "teleop/error.hpp"
#include "teleop/fieldbus/cia402_eds.hpp"

namespace teleop::fieldbus {

using canopen::NmtCommand;
using canopen::NmtState;
using canopen::PdoEntry;
using canopen::PdoMapping;
using cia402::DriveState;
using proto::can::CanFrame;
namespace obj = cia402::obj;
namespace obj301 = cia402::obj301;

namespace {

/// Frames read per Read at most (bounds the cycle; the rest waits for the next one).
constexpr int kMaxFramesPerRead = 64;
/// Poll step of the set-up waits.
constexpr std::uint64_t kSetupPoll_ns = 500'000;

std::uint64_t MsToNs(double ms) noexcept { return static_cast<std::uint64_t>(std::llround(std::max(0.0, ms) * 1e6)); }

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

std::int32_t ClampToI32(double x) noexcept {
  return static_cast<std::int32_t>(std::clamp<double>(std::round(x), -2147483647.0, 2147483647.0));
}

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
  }
  return "invalid";
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
  if (!canopen::IsValidNodeId(config.node_id)) fail("node_id must be 1..127");
  if (config.host_node_id > canopen::kMaxNodeId || config.host_node_id == config.node_id) {
    fail("host_node_id must be 0 (no host heartbeat) or 1..127 and differ from node_id");
  }
  if (!Positive(config.cycle_period_s) || config.cycle_period_s > 4.0) fail("cycle_period_s must be in (0, 4] s");
  if (!(config.host_heartbeat_period_ms >= 0.0) || config.host_heartbeat_period_ms > 65535.0) {
    fail("host_heartbeat_period_ms must be 0..65535");
  }
  if (!(config.drive_heartbeat_period_ms >= 0.0) || config.drive_heartbeat_period_ms > 65535.0) {
    fail("drive_heartbeat_period_ms must be 0..65535");
  }
  if (config.drive_heartbeat_period_ms > 0.0 && !(config.heartbeat_timeout_ms > config.drive_heartbeat_period_ms)) {
    fail(fmt::format("heartbeat_timeout_ms ({:g}) must exceed drive_heartbeat_period_ms ({:g})",
                     config.heartbeat_timeout_ms, config.drive_heartbeat_period_ms));
  }
  if (!Positive(config.boot_timeout_ms)) fail("boot_timeout_ms must be > 0");
  if (!(config.drive_consumer_timeout_ms >= 0.0) || config.drive_consumer_timeout_ms > 65535.0) {
    fail("drive_consumer_timeout_ms must be 0..65535");
  }
  if (config.drive_consumer_timeout_ms > 0.0 &&
      (config.host_node_id == 0 || !(config.drive_consumer_timeout_ms > config.host_heartbeat_period_ms) ||
       config.host_heartbeat_period_ms <= 0.0)) {
    fail(
        "drive_consumer_timeout_ms needs a host heartbeat (host_node_id, host_heartbeat_period_ms > 0) faster "
        "than it");
  }
  if (!Positive(config.state_timeout_ms) || !Positive(config.stale_after_ms)) {
    fail("state_timeout_ms and stale_after_ms must be > 0");
  }
  const Cia402Scaling& s = config.scaling;
  if (!Positive(s.rated_torque_Nm) || !Positive(s.position_rad_per_count) || !Positive(s.velocity_rad_per_s_per_unit) ||
      (s.sign != 1.0 && s.sign != -1.0)) {
    fail("scaling: rated_torque_Nm, position_rad_per_count, velocity_rad_per_s_per_unit must be > 0, sign +1 or -1");
  }
  if (!Positive(config.max_torque_Nm) || config.max_torque_Nm > s.rated_torque_Nm * 32.767) {
    fail(fmt::format("max_torque_Nm must be in (0, {:g}] (32767 per mille of the rated torque)",
                     s.rated_torque_Nm * 32.767));
  }
  if ((config.sync_cob_id & ~0x7FFu) != 0 || config.sync_cob_id == 0) fail("sync_cob_id must be an 11-bit COB-ID");
  const auto mode = static_cast<std::int8_t>(config.mode);
  if (mode != cia402::kModeCyclicSynchronousPosition && mode != cia402::kModeCyclicSynchronousVelocity &&
      mode != cia402::kModeCyclicSynchronousTorque) {
    fail(fmt::format("mode {} is not a cyclic synchronous mode (8 position, 9 velocity, 10 torque)", mode));
  }
  if (!(config.max_velocity_rad_per_s >= 0.0) || !std::isfinite(config.max_velocity_rad_per_s)) {
    fail("max_velocity_rad_per_s must be >= 0 (0: no clamp)");
  }
  if (config.halt_option_code && (*config.halt_option_code < 1 || *config.halt_option_code > 4)) {
    fail("halt_option_code must be 1..4");
  }
  if (config.mode != Cia402Mode::kCyclicSynchronousTorque &&
      SameMappings(config.rpdos, Cia402DriveConfig::DefaultRpdos())) {
    config_.rpdos = Cia402DriveConfig::DefaultRpdos(config.mode);
  }
  // PDOs.
  auto take = [&](const std::vector<PdoMapping>& list, std::array<PdoMapping, 4>& out, int& count, bool tpdo) {
    const char* what = tpdo ? "tpdos" : "rpdos";
    if (list.empty() || list.size() > 4) fail(fmt::format("{}: 1..4 PDOs", what));
    for (const PdoMapping& m : list) {
      const canopen::PdoMappingStatus st = canopen::CheckPdoMapping(m);
      if (st != canopen::PdoMappingStatus::kOk) {
        fail(fmt::format("{} PDO {}: {}", what, m.number, canopen::ToString(st)));
      }
      if (m.transmission_type > 240) {
        fail(fmt::format("{} PDO {}: cyclic synchronous mode needs a synchronous transmission type (1..240)", what,
                         m.number));
      }
      for (int k = 0; k < count; ++k) {
        if (out[static_cast<std::size_t>(k)].number == m.number) fail(fmt::format("{}: PDO {} twice", what, m.number));
      }
      out[static_cast<std::size_t>(count++)] = m;
    }
  };
  take(config_.rpdos, rpdo_, rpdo_count_, false);
  take(config.tpdos, tpdo_, tpdo_count_, true);
  auto find = [&](const std::array<PdoMapping, 4>& list, int count, std::uint16_t index, std::uint8_t bits) {
    Slot slot{};
    for (int p = 0; p < count; ++p) {
      const PdoMapping& m = list[static_cast<std::size_t>(p)];
      for (int e = 0; e < m.entry_count; ++e) {
        const PdoEntry& entry = m.entries[static_cast<std::size_t>(e)];
        if (entry.index != index || entry.subindex != 0) continue;
        if (entry.bits != bits)
          fail(fmt::format("object 0x{:04X} is {} bits, mapped with {}", index, bits, entry.bits));
        if (slot.pdo >= 0) fail(fmt::format("object 0x{:04X} mapped twice", index));
        slot = Slot{p, e};
      }
    }
    return slot;
  };
  controlword_slot_ = find(rpdo_, rpdo_count_, obj::kControlword, 16);
  target_torque_slot_ = find(rpdo_, rpdo_count_, obj::kTargetTorque, 16);
  statusword_slot_ = find(tpdo_, tpdo_count_, obj::kStatusword, 16);
  position_slot_ = find(tpdo_, tpdo_count_, obj::kPositionActual, 32);
  velocity_slot_ = find(tpdo_, tpdo_count_, obj::kVelocityActual, 32);
  torque_slot_ = find(tpdo_, tpdo_count_, obj::kTorqueActual, 16);
  switch (config.mode) {
    case Cia402Mode::kCyclicSynchronousTorque:
      if (controlword_slot_.pdo < 0 || target_torque_slot_.pdo < 0) {
        fail("rpdos must map the controlword 0x6040 and the target torque 0x6071 (16 bits each)");
      }
      target_slot_ = target_torque_slot_;
      break;
    case Cia402Mode::kCyclicSynchronousVelocity:
      target_slot_ = find(rpdo_, rpdo_count_, obj::kTargetVelocity, 32);
      if (controlword_slot_.pdo < 0 || target_slot_.pdo < 0) {
        fail("velocity mode: rpdos must map the controlword 0x6040 (16 bits) and the target velocity 0x60FF (32 bits)");
      }
      break;
    case Cia402Mode::kCyclicSynchronousPosition:
      target_slot_ = find(rpdo_, rpdo_count_, obj::kTargetPosition, 32);
      if (controlword_slot_.pdo < 0 || target_slot_.pdo < 0) {
        fail("position mode: rpdos must map the controlword 0x6040 (16 bits) and the target position 0x607A (32 bits)");
      }
      break;
  }
  if (statusword_slot_.pdo < 0 || position_slot_.pdo < 0 || velocity_slot_.pdo < 0) {
    fail(
        "tpdos must map the statusword 0x6041 (16 bits), position actual 0x6064 and velocity actual 0x606C "
        "(32 bits each)");
  }
  for (int p = 0; p < rpdo_count_; ++p) {
    rpdo_cob_[static_cast<std::size_t>(p)] =
        canopen::PdoCobId(rpdo_[static_cast<std::size_t>(p)], false, config.node_id);
  }
  for (int p = 0; p < tpdo_count_; ++p) {
    tpdo_cob_[static_cast<std::size_t>(p)] =
        canopen::PdoCobId(tpdo_[static_cast<std::size_t>(p)], true, config.node_id);
  }
  for (int a = 0; a < tpdo_count_ + rpdo_count_; ++a) {
    const std::uint32_t id_a =
        a < tpdo_count_ ? tpdo_cob_[static_cast<std::size_t>(a)] : rpdo_cob_[static_cast<std::size_t>(a - tpdo_count_)];
    for (int b = a + 1; b < tpdo_count_ + rpdo_count_; ++b) {
      const std::uint32_t id_b = b < tpdo_count_ ? tpdo_cob_[static_cast<std::size_t>(b)]
                                                 : rpdo_cob_[static_cast<std::size_t>(b - tpdo_count_)];
      if (id_a == id_b) fail(fmt::format("PDO COB-ID 0x{:03X} used twice", id_a));
    }
  }
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
  if (!frame.extended && !frame.fd) {
    for (int p = 0; p < tpdo_count_; ++p) {
      const auto i = static_cast<std::size_t>(p);
      if (frame.id != tpdo_cob_[i]) continue;
      const PdoMapping& m = tpdo_[i];
      if (!canopen::UnpackPdo(
              m, frame, std::span<std::uint32_t>(tpdo_values_[i].data(), static_cast<std::size_t>(m.entry_count)))) {
        ++counters_.tpdos_rejected;
        return;
      }
      ++counters_.tpdos_received;
      tpdo_stamp_ns_[i] = now;
      tpdo_seen_mask_ |= 1u << p;
      if (statusword_slot_.pdo == p) {
        statusword_ = static_cast<std::uint16_t>(tpdo_values_[i][static_cast<std::size_t>(statusword_slot_.entry)]);
        SetDriveState(cia402::DecodeStatusword(statusword_));
      }
      return;
    }
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
  const std::string where = fmt::format("CiA 402 drive node {}: configure", config_.node_id);
  bool consumer_armed = false;  // 0x1016:01 written non-zero: undone if anything after it fails
  try {
    if (!config_.eds_file.empty()) {  // before any bus traffic: a drive whose EDS does not fit is never touched
      const std::vector<std::string> problems = CheckAgainstEds(canopen::Eds::Load(config_.eds_file), config_);
      if (!problems.empty()) {
        std::string text = fmt::format("{}: the EDS does not fit the configuration:", where);
        for (const std::string& p : problems) text += "\n  " + p;
        throw Error(text);
      }
    }
    CanFrame frame{};
    while (port_.Read(frame)) HandleFrame(frame);  // whatever came before is not this bring-up's
    boot_seen_ = false;
    const NmtCommand reset = config_.reset_node ? NmtCommand::kResetNode : NmtCommand::kResetCommunication;
    if (port_.Write(canopen::EncodeNmt(reset, config_.node_id)) != transport::CanWriteStatus::kOk) {
      throw Error(where + ": the CAN port refused the NMT command");
    }
    WaitForBoot();
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
    // Heartbeats: the drive's producer, and its consumer of the host.
    sdo_.Download(obj301::kProducerHeartbeatTime, 0,
                  static_cast<std::uint32_t>(std::lround(config_.drive_heartbeat_period_ms)), 2);
    const std::uint32_t consumer = config_.drive_consumer_timeout_ms > 0.0
                                       ? (std::uint32_t{config_.host_node_id} << 16) |
                                             static_cast<std::uint32_t>(std::lround(config_.drive_consumer_timeout_ms))
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
    // PDOs: the configured ones written and read back, the others switched off.
    for (int n = 1; n <= 4; ++n) {
      bool rpdo_used = false;
      bool tpdo_used = false;
      for (int p = 0; p < rpdo_count_; ++p) {
        if (rpdo_[static_cast<std::size_t>(p)].number == n) {
          WritePdo(rpdo_[static_cast<std::size_t>(p)], false);
          rpdo_used = true;
        }
      }
      for (int p = 0; p < tpdo_count_; ++p) {
        if (tpdo_[static_cast<std::size_t>(p)].number == n) {
          WritePdo(tpdo_[static_cast<std::size_t>(p)], true);
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
      sdo_.Download(obj::kFaultReactionOptionCode, 0, static_cast<std::uint16_t>(*config_.fault_reaction_option_code),
                    2);
    }
    if (config_.halt_option_code) {
      sdo_.Download(obj::kHaltOptionCode, 0, static_cast<std::uint16_t>(*config_.halt_option_code), 2);
    }
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
    for (int p = 0; p < tpdo_count_; ++p) tpdo_stamp_ns_[static_cast<std::size_t>(p)] = now;
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

Cia402Status Cia402Drive::Read(Cia402Reading& reading) noexcept {
  CanFrame frame{};
  for (int i = 0; i < kMaxFramesPerRead && port_.Read(frame); ++i) HandleFrame(frame);
  if (!active_) return Cia402Status::kNotActive;
  const std::uint64_t now = timebase_.now_ns();
  const unsigned all = (1u << tpdo_count_) - 1u;
  const bool fresh = (tpdo_seen_mask_ & all) == all;
  if (fresh) {
    tpdo_seen_mask_ = 0;
    const auto value = [&](const Slot& s) {
      return tpdo_values_[static_cast<std::size_t>(s.pdo)][static_cast<std::size_t>(s.entry)];
    };
    const Cia402Scaling& sc = config_.scaling;
    newest_.position_rad = sc.sign * sc.position_rad_per_count * canopen::SignExtend(value(position_slot_), 32);
    newest_.velocity_rad_per_s =
        sc.sign * sc.velocity_rad_per_s_per_unit * canopen::SignExtend(value(velocity_slot_), 32);
    newest_.torque_Nm = torque_slot_.pdo >= 0
                            ? sc.sign * sc.rated_torque_Nm * 1e-3 * canopen::SignExtend(value(torque_slot_), 16)
                            : commanded_torque_Nm_;
    newest_.stamp_ns = 0;
    for (int p = 0; p < tpdo_count_; ++p) {
      newest_.stamp_ns = std::max(newest_.stamp_ns, tpdo_stamp_ns_[static_cast<std::size_t>(p)]);
    }
  }
  newest_.statusword = statusword_;
  newest_.state = drive_state_;
  newest_.fresh = fresh;
  reading = newest_;
  std::uint64_t oldest = now;
  for (int p = 0; p < tpdo_count_; ++p) oldest = std::min(oldest, tpdo_stamp_ns_[static_cast<std::size_t>(p)]);
  if (bus_off_) return Cia402Status::kBusOff;
  if (HeartbeatExpired(now)) return Cia402Status::kHeartbeatLost;
  if (fault_latched_ || drive_state_ == DriveState::kFault || drive_state_ == DriveState::kFaultReactionActive) {
    return Cia402Status::kFault;
  }
  if (now > oldest + MsToNs(config_.stale_after_ms)) return Cia402Status::kStale;
  if (drive_state_ != DriveState::kOperationEnabled) return Cia402Status::kNotEnabled;
  return fresh ? Cia402Status::kOk : Cia402Status::kNoNewData;
}

Cia402Status Cia402Drive::Write(double setpoint) noexcept {
  if (!active_) return Cia402Status::kNotActive;
  const std::uint64_t now = timebase_.now_ns();
  Cia402Status status = Cia402Status::kOk;
  // No burst of SYNCs (a late loop catching up): within half a period of the last SYNC nothing is sent, so the
  // target of the last SYNC stays the reference of the position step.
  if (config_.produce_sync && sync_sent_ && now < last_sync_ns_ + half_period_ns_) {
    ++counters_.syncs_skipped;
    if (!SendHeartbeatIfDue(now)) status = Cia402Status::kWriteFailed;
    if (bus_off_) return Cia402Status::kBusOff;
    if (heartbeat_lost_) return Cia402Status::kHeartbeatLost;
    if (fault_latched_) return Cia402Status::kFault;
    return status;
  }
  const bool unsafe = fault_latched_ || heartbeat_lost_ || bus_off_;
  const Cia402Scaling& sc = config_.scaling;
  std::uint32_t raw = 0;
  switch (config_.mode) {
    case Cia402Mode::kCyclicSynchronousTorque: {
      double torque_Nm = setpoint;
      if (!std::isfinite(torque_Nm)) {
        ++counters_.non_finite_commands;
        torque_Nm = 0.0;
      }
      if (std::abs(torque_Nm) > config_.max_torque_Nm) {
        ++counters_.torque_clamped;
        torque_Nm = std::clamp(torque_Nm, -config_.max_torque_Nm, config_.max_torque_Nm);
      }
      if (quick_stop_requested_ || unsafe) torque_Nm = 0.0;
      commanded_torque_Nm_ = torque_Nm;
      raw = static_cast<std::uint16_t>(
          static_cast<std::int16_t>(std::lround(sc.sign * torque_Nm / sc.rated_torque_Nm * 1000.0)));
      break;
    }
    case Cia402Mode::kCyclicSynchronousVelocity: {
      double velocity = setpoint;
      if (!std::isfinite(velocity)) {
        ++counters_.non_finite_commands;
        velocity = 0.0;
      }
      const double limit = config_.max_velocity_rad_per_s;
      if (limit > 0.0 && std::abs(velocity) > limit) {
        ++counters_.velocity_clamped;
        velocity = std::clamp(velocity, -limit, limit);
      }
      if (quick_stop_requested_ || unsafe) velocity = 0.0;
      raw = static_cast<std::uint32_t>(ClampToI32(sc.sign * velocity / sc.velocity_rad_per_s_per_unit));
      break;
    }
    case Cia402Mode::kCyclicSynchronousPosition: {
      double position = setpoint;
      if (!std::isfinite(position)) {
        ++counters_.non_finite_commands;
        position = position_target_rad_;
      }
      if (quick_stop_requested_ || unsafe) position = position_target_rad_;
      const double step = config_.max_velocity_rad_per_s * config_.cycle_period_s;
      if (step > 0.0 && std::abs(position - position_target_rad_) > step) {
        ++counters_.position_step_clamped;
        position = std::clamp(position, position_target_rad_ - step, position_target_rad_ + step);
      }
      position_target_rad_ = position;
      raw = static_cast<std::uint32_t>(ClampToI32(sc.sign * position / sc.position_rad_per_count));
      break;
    }
  }
  controlword_ = quick_stop_requested_ ? cia402::cw::kCmdQuickStop : cia402::cw::kCmdEnableOperation;
  if (halt_requested_) controlword_ |= cia402::cw::kHalt;
  rpdo_values_[static_cast<std::size_t>(controlword_slot_.pdo)][static_cast<std::size_t>(controlword_slot_.entry)] =
      controlword_;
  rpdo_values_[static_cast<std::size_t>(target_slot_.pdo)][static_cast<std::size_t>(target_slot_.entry)] = raw;
  for (int p = 0; p < rpdo_count_; ++p) {
    const auto i = static_cast<std::size_t>(p);
    CanFrame frame{};
    if (!canopen::PackPdo(
            rpdo_[i], rpdo_cob_[i],
            std::span<const std::uint32_t>(rpdo_values_[i].data(), static_cast<std::size_t>(rpdo_[i].entry_count)),
            frame) ||
        port_.Write(frame) != transport::CanWriteStatus::kOk) {
      ++counters_.write_failures;
      status = Cia402Status::kWriteFailed;
      continue;
    }
    ++counters_.rpdos_sent;
  }
  if (config_.produce_sync) {
    if (port_.Write(canopen::EncodeSync(config_.sync_cob_id)) != transport::CanWriteStatus::kOk) {
      ++counters_.write_failures;
      status = Cia402Status::kWriteFailed;
    } else {
      ++counters_.syncs_sent;
      sync_sent_ = true;
      last_sync_ns_ = now;
    }
  }
  if (!SendHeartbeatIfDue(now)) status = Cia402Status::kWriteFailed;
  if (bus_off_) return Cia402Status::kBusOff;
  if (heartbeat_lost_) return Cia402Status::kHeartbeatLost;
  if (fault_latched_) return Cia402Status::kFault;
  return status;
}

void Cia402Drive::RequestQuickStop() noexcept { quick_stop_requested_ = true; }

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

std::string Cia402Drive::Describe() const {
  std::string text = fmt::format("CiA 402 node {} on {}: RPDO", config_.node_id, port_.Describe());
  for (int p = 0; p < rpdo_count_; ++p) text += fmt::format(" 0x{:03X}", rpdo_cob_[static_cast<std::size_t>(p)]);
  text += ", TPDO";
  for (int p = 0; p < tpdo_count_; ++p) text += fmt::format(" 0x{:03X}", tpdo_cob_[static_cast<std::size_t>(p)]);
  text += fmt::format(", SYNC 0x{:03X} {} every {:g} ms, heartbeat {:g} ms (timeout {:g} ms)", config_.sync_cob_id,
                      config_.produce_sync ? "produced" : "not produced", config_.cycle_period_s * 1e3,
                      config_.drive_heartbeat_period_ms, config_.heartbeat_timeout_ms);
  return text;
}

}  // namespace teleop::fieldbus
