// The simulated CiA 402 drive's SDO server (CiA 301 expedited and segmented transfers, aborts) and its object
// dictionary: one row per index range in SimulatedCia402Drive::kDictionary, one function per row.
#include <algorithm>
#include <cmath>

#include "simulated_cia402_dictionary.hpp"
#include "teleop/fieldbus/canopen_sdo.hpp"
#include "teleop/fieldbus/simulated_cia402_drive.hpp"

namespace teleop::fieldbus {

using canopen::PdoEntry;
using canopen::PdoMapping;
using proto::can::CanFrame;
using simulated::RoundToI32;
namespace abort_code = canopen::sdo_abort;
namespace obj = cia402::obj;
namespace obj301 = cia402::obj301;

namespace {

/// A manufacturer-specific VISIBLE_STRING (read-write, up to 32 bytes): the object segmented downloads are tested on.
constexpr std::uint16_t kLabelObject = 0x2000;

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

}  // namespace

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
  if (m.kind == Kind::kUploadRequest && is_bytes) return UploadBytes(m, bytes, now_ns);
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

void SimulatedCia402Drive::UploadBytes(const canopen::SdoMessage& m, std::span<const std::uint8_t> bytes,
                                       std::uint64_t now_ns) noexcept {
  using Phase = SdoTransfer::Phase;
  if (!bytes.empty() && bytes.size() <= 4) {  // expedited
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

/// One SDO access of one object: the request, and where an upload's value goes.
struct SimulatedCia402Drive::ObjectAccess {
  const canopen::SdoMessage& m;
  std::uint32_t& out_value;
  std::uint8_t& out_size;
  std::uint16_t index = m.index;
  std::uint8_t sub = m.subindex;
  std::uint32_t value = m.value;
  bool upload = m.kind == canopen::SdoMessage::Kind::kUploadRequest;

  /// An upload's answer: 0 (no abort).
  std::uint32_t Reply(std::uint32_t v, std::uint8_t size) const noexcept {
    out_value = v;
    out_size = size;
    return 0;
  }
  /// The length of a download against the object's: 0 or the abort code.
  std::uint32_t Length(std::uint8_t size) const noexcept {
    if (m.size == size) return 0;
    return m.size > size ? abort_code::kLengthTooHigh : abort_code::kLengthTooLow;
  }
};

/// The object dictionary, by index range: who serves which objects (CiA 301 communication area 0x1000-0x1FFF,
/// CiA 402 drive profile 0x6000-0x6FFF).
const std::array<SimulatedCia402Drive::ObjectRange, 6> SimulatedCia402Drive::kDictionary = {{
    {obj301::kRpdoCommunication, obj301::kRpdoCommunication + 3, &SimulatedCia402Drive::AccessRpdoCommunication},
    {obj301::kTpdoCommunication, obj301::kTpdoCommunication + 3, &SimulatedCia402Drive::AccessTpdoCommunication},
    {obj301::kRpdoMapping, obj301::kRpdoMapping + 3, &SimulatedCia402Drive::AccessPdoMapping},
    {obj301::kTpdoMapping, obj301::kTpdoMapping + 3, &SimulatedCia402Drive::AccessPdoMapping},
    {0x1000, 0x1FFF, &SimulatedCia402Drive::AccessCommunication},
    {0x2000, 0xFFFF, &SimulatedCia402Drive::AccessDrive},
}};

std::uint32_t SimulatedCia402Drive::Access(const canopen::SdoMessage& m, std::uint32_t& out_value,
                                           std::uint8_t& out_size) noexcept {
  const ObjectAccess a{m, out_value, out_size};
  for (const ObjectRange& r : kDictionary) {
    if (m.index >= r.first && m.index <= r.last) return (this->*r.access)(a);
  }
  return abort_code::kNoObject;
}

std::uint32_t SimulatedCia402Drive::AccessRpdoCommunication(const ObjectAccess& a) noexcept {
  return AccessPdoCommunication(a, false);
}

std::uint32_t SimulatedCia402Drive::AccessTpdoCommunication(const ObjectAccess& a) noexcept {
  return AccessPdoCommunication(a, true);
}

std::uint32_t SimulatedCia402Drive::AccessPdoCommunication(const ObjectAccess& a, bool tpdo) noexcept {
  Dictionary& d = *dict_;
  const auto i = static_cast<std::size_t>(a.index - (tpdo ? obj301::kTpdoCommunication : obj301::kRpdoCommunication));
  std::uint32_t& cob = tpdo ? d.tpdo_cob[i] : d.rpdo_cob[i];
  bool& valid_now = tpdo ? d.tpdo_valid[i] : d.rpdo_valid[i];
  PdoMapping& pdo = tpdo ? d.tpdo[i] : d.rpdo[i];
  if (a.sub == 0) return a.upload ? a.Reply(2, 1) : abort_code::kReadOnly;
  if (a.sub == 1) {
    // No RTR here: bit 30 reads 1 and must be written 1 (devices without RTR refuse 0, as CiA 301 lets them); no
    // 29-bit identifiers; bits 0..29 are not changed while the PDO is valid (CiA 301).
    if (a.upload) {
      return a.Reply(cob | canopen::cob::kNoRtrBit | (valid_now ? 0u : canopen::cob::kInvalidBit), 4);
    }
    if (const std::uint32_t c = a.Length(4)) return c;
    const bool valid = (a.value & canopen::cob::kInvalidBit) == 0;
    if ((a.value & canopen::cob::kNoRtrBit) == 0 || (a.value & 0x3FFF'F800u) != 0) return abort_code::kValueRange;
    if (valid && valid_now && (a.value & 0x7FFu) != cob) return abort_code::kValueRange;
    valid_now = valid;
    cob = a.value & 0x7FFu;
    return 0;
  }
  if (a.sub == 2) {
    if (a.upload) return a.Reply(pdo.transmission_type, 1);
    if (const std::uint32_t c = a.Length(1)) return c;
    if (a.value == 0 || (a.value > 240 && a.value < 254) || a.value > 255) return abort_code::kValueRange;
    pdo.transmission_type = static_cast<std::uint8_t>(a.value);
    if (tpdo) d.tpdo_sync_count[i] = 0;
    return 0;
  }
  return abort_code::kNoSubindex;
}

std::uint32_t SimulatedCia402Drive::AccessPdoMapping(const ObjectAccess& a) noexcept {
  Dictionary& d = *dict_;
  const bool tpdo_map = a.index >= obj301::kTpdoMapping;
  const auto i = static_cast<std::size_t>(a.index - (tpdo_map ? obj301::kTpdoMapping : obj301::kRpdoMapping));
  PdoMapping& map = tpdo_map ? d.tpdo[i] : d.rpdo[i];
  const bool valid = tpdo_map ? d.tpdo_valid[i] : d.rpdo_valid[i];
  if (a.sub > canopen::kMaxPdoEntries) return abort_code::kNoSubindex;
  if (a.upload) {
    if (a.sub == 0) return a.Reply(static_cast<std::uint32_t>(map.entry_count), 1);
    return a.Reply(map.entries[a.sub - 1u].MappingValue(), 4);
  }
  // CiA 301 PDO mapping procedure: the mapping changes only while the PDO is invalid; entries only while sub 0 is 0.
  if (valid) return abort_code::kCannotStoreState;
  if (a.sub == 0) {
    if (const std::uint32_t c = a.Length(1)) return c;
    if (a.value > canopen::kMaxPdoEntries) return abort_code::kValueRange;
    int bits = 0;
    for (std::uint32_t k = 0; k < a.value; ++k) bits += map.entries[k].bits;
    if (bits > 64) return abort_code::kPdoTooLong;
    map.entry_count = static_cast<int>(a.value);
    return 0;
  }
  if (map.entry_count != 0) return abort_code::kUnsupportedAccess;
  if (const std::uint32_t c = a.Length(4)) return c;
  const PdoEntry e = PdoEntry::FromMappingValue(a.value);
  const int bytes = MappableBytes(e.index, e.subindex, tpdo_map);
  if (bytes == 0) return abort_code::kNotMappable;
  if (e.bits != 8 * bytes) return abort_code::kLengthMismatch;
  map.entries[a.sub - 1u] = e;
  return 0;
}

std::uint32_t SimulatedCia402Drive::AccessCommunication(const ObjectAccess& a) noexcept {
  Dictionary& d = *dict_;
  const std::uint16_t index = a.index;
  switch (index) {
    case obj301::kDeviceType:
      if (a.sub != 0) return abort_code::kNoSubindex;
      return a.upload ? a.Reply(0x0002'0000u | cia402::kDeviceProfile402, 4) : abort_code::kReadOnly;
    case obj301::kErrorRegister:
      if (a.sub != 0) return abort_code::kNoSubindex;
      return a.upload ? a.Reply(error_register_, 1) : abort_code::kReadOnly;
    case obj301::kErrorHistory:
      if (a.sub == 0) {
        if (a.upload) return a.Reply(error_history_count_, 1);
        if (const std::uint32_t c = a.Length(1)) return c;
        if (a.value != 0) return abort_code::kValueRange;  // only 0 (clear) may be written
        error_history_count_ = 0;
        return 0;
      }
      if (a.sub > error_history_.size()) return abort_code::kNoSubindex;
      if (!a.upload) return abort_code::kReadOnly;
      if (a.sub > error_history_count_) return abort_code::kNoData;
      return a.Reply(error_history_[a.sub - 1u], 4);
    case obj301::kCobIdSync:
      if (a.sub != 0) return abort_code::kNoSubindex;
      if (a.upload) return a.Reply(d.sync_cob, 4);
      if (const std::uint32_t c = a.Length(4)) return c;
      d.sync_cob = a.value & 0x7FFu;
      return 0;
    case obj301::kCommunicationCyclePeriod:
      if (a.sub != 0) return abort_code::kNoSubindex;
      if (a.upload) return a.Reply(d.cycle_period_us, 4);
      if (const std::uint32_t c = a.Length(4)) return c;
      d.cycle_period_us = a.value;
      return 0;
    case obj301::kCobIdEmcy:
      if (a.sub != 0) return abort_code::kNoSubindex;
      return a.upload ? a.Reply(canopen::cob::kEmcy + config_.node_id, 4) : abort_code::kReadOnly;
    case obj301::kConsumerHeartbeatTime:
      if (a.sub == 0) return a.upload ? a.Reply(1, 1) : abort_code::kReadOnly;
      if (a.sub != 1) return abort_code::kNoSubindex;
      if (a.upload) return a.Reply(d.consumer_heartbeat, 4);
      if (const std::uint32_t c = a.Length(4)) return c;
      d.consumer_heartbeat = a.value & 0x00FF'FFFFu;
      host_heartbeat_seen_ = false;  // re-armed by the next heartbeat
      return 0;
    case obj301::kProducerHeartbeatTime:
      if (a.sub != 0) return abort_code::kNoSubindex;
      if (a.upload) return a.Reply(d.producer_heartbeat_ms, 2);
      if (const std::uint32_t c = a.Length(2)) return c;
      d.producer_heartbeat_ms = static_cast<std::uint16_t>(a.value);
      next_heartbeat_ns_ = last_ns_;  // the first heartbeat at once
      return 0;
    case obj301::kIdentity:
      if (!a.upload) return abort_code::kReadOnly;
      if (a.sub == 0) return a.Reply(4, 1);
      if (a.sub == 1) return a.Reply(config_.vendor_id, 4);
      if (a.sub >= 2 && a.sub <= 4) return a.Reply(a.sub == 2 ? 0x402u : 1u, 4);
      return abort_code::kNoSubindex;
    default:
      break;
  }
  return abort_code::kNoObject;
}

std::uint32_t SimulatedCia402Drive::AccessDrive(const ObjectAccess& a) noexcept {
  const std::uint16_t index = a.index;
  if (a.sub != 0) return index >= 0x6000 && index <= 0x6FFF ? abort_code::kNoSubindex : abort_code::kNoObject;
  if (const std::uint32_t code = AccessDriveControl(a); code != kNotServed) return code;
  return AccessDriveValues(a);
}

/// Error code, controlword, statusword, option codes, mode (kNotServed for any other object).
std::uint32_t SimulatedCia402Drive::AccessDriveControl(const ObjectAccess& a) noexcept {
  Dictionary& d = *dict_;
  const std::uint16_t index = a.index;
  switch (index) {
    case obj::kErrorCode:
      return a.upload ? a.Reply(error_code_, 2) : abort_code::kReadOnly;
    case obj::kControlword:
      if (a.upload) return a.Reply(controlword_, 2);
      if (const std::uint32_t c = a.Length(2)) return c;
      controlword_ = static_cast<std::uint16_t>(a.value);
      if (machine_.Apply(controlword_, d.quick_stop_option == 0) == 15) {
        ++counters_.fault_resets;
        error_code_ = 0;
        error_register_ = 0;
        reset_emcy_pending_ = true;  // the "error reset" EMCY follows the SDO response
      }
      return 0;
    case obj::kStatusword:
      return a.upload ? a.Reply(Statusword(), 2) : abort_code::kReadOnly;
    case obj::kQuickStopOptionCode:
    case obj::kFaultReactionOptionCode: {
      std::int16_t& option = index == obj::kQuickStopOptionCode ? d.quick_stop_option : d.fault_reaction_option;
      if (a.upload) return a.Reply(static_cast<std::uint16_t>(option), 2);
      if (const std::uint32_t c = a.Length(2)) return c;
      const auto value = static_cast<std::int16_t>(a.value);
      if (value < 0 || value > 8) return abort_code::kValueRange;
      option = value;
      return 0;
    }
    case obj::kModesOfOperation: {
      if (a.upload) return a.Reply(static_cast<std::uint8_t>(mode_), 1);
      if (const std::uint32_t c = a.Length(1)) return c;
      const auto mode = static_cast<std::int8_t>(a.value);
      if (mode != 0 && (config_.supported_modes & cia402::SupportedModeBit(mode)) == 0) {
        return abort_code::kValueRange;  // a mode 0x6502 does not list
      }
      previous_display_ = DisplayedMode();
      mode_ = mode;
      mode_display_at_ns_ = last_ns_ + static_cast<std::uint64_t>(std::max(0.0, config_.mode_display_delay_ms) * 1e6);
      return 0;
    }
    default:
      return kNotServed;
  }
}

/// Targets, decelerations, actual values, limits.
std::uint32_t SimulatedCia402Drive::AccessDriveValues(const ObjectAccess& a) noexcept {
  Dictionary& d = *dict_;
  const std::uint16_t index = a.index;
  switch (index) {
    case obj::kTargetPosition:
    case obj::kTargetVelocity: {
      std::int32_t& target = index == obj::kTargetPosition ? target_position_ : target_velocity_;
      std::int32_t& pending = index == obj::kTargetPosition ? pending_target_position_ : pending_target_velocity_;
      if (a.upload) return a.Reply(static_cast<std::uint32_t>(target), 4);
      if (const std::uint32_t c = a.Length(4)) return c;
      target = static_cast<std::int32_t>(a.value);
      pending = target;
      return 0;
    }
    case obj::kProfileDeceleration:
    case obj::kQuickStopDeceleration: {
      std::uint32_t& decel = index == obj::kProfileDeceleration ? d.profile_deceleration : d.quick_stop_deceleration;
      if (a.upload) return a.Reply(decel, 4);
      if (const std::uint32_t c = a.Length(4)) return c;
      decel = a.value;
      return 0;
    }
    case obj::kHaltOptionCode: {
      if (a.upload) return a.Reply(static_cast<std::uint16_t>(d.halt_option), 2);
      if (const std::uint32_t c = a.Length(2)) return c;
      const auto value = static_cast<std::int16_t>(a.value);
      if (value < 1 || value > 4) return abort_code::kValueRange;
      d.halt_option = value;
      return 0;
    }
    case obj::kModesOfOperationDisplay:
      return a.upload ? a.Reply(static_cast<std::uint8_t>(DisplayedMode()), 1) : abort_code::kReadOnly;
    case obj::kPositionActual:
      return a.upload
                 ? a.Reply(static_cast<std::uint32_t>(RoundToI32(position_rad_ / config_.position_rad_per_count)), 4)
                 : abort_code::kReadOnly;
    case obj::kVelocityActual:
      return a.upload ? a.Reply(static_cast<std::uint32_t>(
                                    RoundToI32(velocity_rad_per_s_ / config_.velocity_rad_per_s_per_unit)),
                                4)
                      : abort_code::kReadOnly;
    case obj::kTargetTorque:
      if (a.upload) return a.Reply(static_cast<std::uint16_t>(target_torque_), 2);
      if (const std::uint32_t c = a.Length(2)) return c;
      target_torque_ = static_cast<std::int16_t>(a.value);
      pending_target_torque_ = target_torque_;
      return 0;
    case obj::kMaxTorque:
      if (a.upload) return a.Reply(d.max_torque, 2);
      if (const std::uint32_t c = a.Length(2)) return c;
      d.max_torque = static_cast<std::uint16_t>(a.value);
      return 0;
    case obj::kRatedTorque:
      return a.upload ? a.Reply(config_.rated_torque_mNm, 4) : abort_code::kReadOnly;
    case obj::kTorqueActual:
      return a.upload
                 ? a.Reply(
                       static_cast<std::uint16_t>(RoundToI32(applied_torque_Nm_ / (config_.rated_torque_mNm * 1e-6))),
                       2)
                 : abort_code::kReadOnly;
    case obj::kSupportedDriveModes:
      return a.upload ? a.Reply(config_.supported_modes, 4) : abort_code::kReadOnly;
    default:
      return abort_code::kNoObject;
  }
}

}  // namespace teleop::fieldbus
