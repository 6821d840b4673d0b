#include "teleop/fieldbus/canopen_sdo.hpp"

#include <algorithm>

namespace teleop::fieldbus::canopen {

namespace {

CanFrame SdoFrame(std::uint32_t cob_id, std::uint8_t command, std::uint16_t index, std::uint8_t subindex) noexcept {
  CanFrame f{};
  f.id = cob_id;
  f.len = 8;
  f.data[0] = command;
  f.data[1] = static_cast<std::uint8_t>(index);
  f.data[2] = static_cast<std::uint8_t>(index >> 8);
  f.data[3] = subindex;
  return f;
}

void PutValue(CanFrame& f, std::uint32_t value) noexcept {
  for (std::size_t i = 0; i < 4; ++i) f.data[4 + i] = static_cast<std::uint8_t>(value >> (8 * i));
}

std::uint32_t GetValue(const CanFrame& f) noexcept {
  std::uint32_t v = 0;
  for (std::size_t i = 4; i > 0; --i) v = v << 8 | f.data[3 + i];
  return v;
}

std::uint32_t Masked(std::uint32_t value, std::uint8_t size) noexcept {
  return size >= 4 ? value : value & ((1u << (8 * size)) - 1u);
}

/// Expedited with size indicated: cs | (4 - n) << 2 | e (bit 1) | s (bit 0).
std::uint8_t ExpeditedCommand(std::uint8_t cs, std::uint8_t size) noexcept {
  return static_cast<std::uint8_t>(cs << 5 | (4 - size) << 2 | 0x03);
}

CanFrame SegmentFrame(std::uint32_t cob_id, std::uint8_t cs, bool toggle, std::span<const std::uint8_t> data,
                      bool last) noexcept {
  const std::size_t size = std::min(data.size(), kSdoSegmentBytes);
  CanFrame f{};
  f.id = cob_id;
  f.len = 8;
  f.data[0] =
      static_cast<std::uint8_t>(cs << 5 | (toggle ? 0x10 : 0) | (kSdoSegmentBytes - size) << 1 | (last ? 1 : 0));
  for (std::size_t i = 0; i < size; ++i) f.data[1 + i] = data[i];
  return f;
}

/// A segment (ccs 0 / scs 0): t in bit 4, n in bits 3..1, c in bit 0, data in bytes 1..7.
void DecodeSegment(const CanFrame& frame, SdoMessage& out) noexcept {
  const std::uint8_t c = frame.data[0];
  out.index = 0;
  out.subindex = 0;
  out.toggle = (c & 0x10) != 0;
  out.last = (c & 0x01) != 0;
  out.segment_size = static_cast<std::uint8_t>(kSdoSegmentBytes - ((c >> 1) & 0x7));
  for (std::size_t i = 0; i < out.segment_size; ++i) out.segment[i] = frame.data[1 + i];
}

bool Common(const CanFrame& frame, SdoMessage& out) noexcept {
  if (frame.error || frame.fd || frame.extended || frame.remote || frame.len != 8) return false;
  out = SdoMessage{};
  out.index = static_cast<std::uint16_t>(frame.data[1] | frame.data[2] << 8);
  out.subindex = frame.data[3];
  return true;
}

}  // namespace

const char* DescribeSdoAbort(std::uint32_t code) noexcept {
  switch (code) {
    case sdo_abort::kToggleBit:
      return "Toggle bit not alternated";
    case sdo_abort::kTimeout:
      return "SDO protocol timed out";
    case sdo_abort::kBadCommand:
      return "Client/server command specifier not valid or unknown";
    case sdo_abort::kOutOfMemory:
      return "Out of memory";
    case sdo_abort::kUnsupportedAccess:
      return "Unsupported access to an object";
    case sdo_abort::kWriteOnly:
      return "Attempt to read a write only object";
    case sdo_abort::kReadOnly:
      return "Attempt to write a read only object";
    case sdo_abort::kNoObject:
      return "Object does not exist in the object dictionary";
    case sdo_abort::kNotMappable:
      return "Object cannot be mapped to the PDO";
    case sdo_abort::kPdoTooLong:
      return "The number and length of the objects to be mapped would exceed PDO length";
    case sdo_abort::kIncompatibleParameter:
      return "General parameter incompatibility reason";
    case sdo_abort::kHardwareError:
      return "Access failed due to a hardware error";
    case sdo_abort::kLengthMismatch:
      return "Data type does not match, length of service parameter does not match";
    case sdo_abort::kLengthTooHigh:
      return "Data type does not match, length of service parameter too high";
    case sdo_abort::kLengthTooLow:
      return "Data type does not match, length of service parameter too low";
    case sdo_abort::kNoSubindex:
      return "Sub-index does not exist";
    case sdo_abort::kValueRange:
      return "Invalid value for parameter (download only)";
    case sdo_abort::kValueTooHigh:
      return "Value of parameter written too high (download only)";
    case sdo_abort::kValueTooLow:
      return "Value of parameter written too low (download only)";
    case sdo_abort::kNoData:
      return "No data available";
    case sdo_abort::kGeneral:
      return "General error";
    case sdo_abort::kCannotStore:
      return "Data cannot be transferred or stored to the application";
    case sdo_abort::kCannotStoreLocal:
      return "Data cannot be transferred or stored to the application because of local control";
    case sdo_abort::kCannotStoreState:
      return "Data cannot be transferred or stored to the application because of the present device state";
    default:
      return "unknown abort code";
  }
}

CanFrame EncodeSdoUploadRequest(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex) noexcept {
  return SdoFrame(cob::kSdoRx + node_id, 0x40, index, subindex);
}

CanFrame EncodeSdoDownloadRequest(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex, std::uint32_t value,
                                  std::uint8_t size) noexcept {
  size = std::clamp<std::uint8_t>(size, 1, 4);
  CanFrame f = SdoFrame(cob::kSdoRx + node_id, ExpeditedCommand(1, size), index, subindex);
  PutValue(f, Masked(value, size));
  return f;
}

CanFrame EncodeSdoUploadResponse(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex, std::uint32_t value,
                                 std::uint8_t size) noexcept {
  size = std::clamp<std::uint8_t>(size, 1, 4);
  CanFrame f = SdoFrame(cob::kSdoTx + node_id, ExpeditedCommand(2, size), index, subindex);
  PutValue(f, Masked(value, size));
  return f;
}

CanFrame EncodeSdoDownloadResponse(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex) noexcept {
  return SdoFrame(cob::kSdoTx + node_id, 0x60, index, subindex);
}

CanFrame EncodeSdoAbort(std::uint32_t cob_id, std::uint16_t index, std::uint8_t subindex,
                        std::uint32_t abort_code) noexcept {
  CanFrame f = SdoFrame(cob_id, 0x80, index, subindex);
  PutValue(f, abort_code);
  return f;
}

CanFrame EncodeSdoInitiateDownloadSegmented(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex,
                                            std::uint32_t size) noexcept {
  CanFrame f = SdoFrame(cob::kSdoRx + node_id, 0x21, index, subindex);
  PutValue(f, size);
  return f;
}

CanFrame EncodeSdoInitiateUploadSegmented(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex,
                                          std::uint32_t size) noexcept {
  CanFrame f = SdoFrame(cob::kSdoTx + node_id, 0x41, index, subindex);
  PutValue(f, size);
  return f;
}

CanFrame EncodeSdoDownloadSegment(std::uint8_t node_id, bool toggle, std::span<const std::uint8_t> data,
                                  bool last) noexcept {
  return SegmentFrame(cob::kSdoRx + node_id, 0, toggle, data, last);
}

CanFrame EncodeSdoDownloadSegmentResponse(std::uint8_t node_id, bool toggle) noexcept {
  CanFrame f{};
  f.id = cob::kSdoTx + node_id;
  f.len = 8;
  f.data[0] = toggle ? 0x30 : 0x20;
  return f;
}

CanFrame EncodeSdoUploadSegmentRequest(std::uint8_t node_id, bool toggle) noexcept {
  CanFrame f{};
  f.id = cob::kSdoRx + node_id;
  f.len = 8;
  f.data[0] = toggle ? 0x70 : 0x60;
  return f;
}

CanFrame EncodeSdoUploadSegment(std::uint8_t node_id, bool toggle, std::span<const std::uint8_t> data,
                                bool last) noexcept {
  return SegmentFrame(cob::kSdoTx + node_id, 0, toggle, data, last);
}

bool DecodeSdoRequest(const CanFrame& frame, SdoMessage& out) noexcept {
  if (!Common(frame, out)) return false;
  // The bits CiA 301 marks x ("not used, always 0") and n where it is "only valid if e = 1 and s = 1" are ignored,
  // as a receiver must: a client that sets them is still understood.
  const std::uint8_t c = frame.data[0];
  const int ccs = c >> 5;
  const bool expedited = (c & 0x02) != 0;
  const bool size_indicated = (c & 0x01) != 0;
  if (ccs == 4) {  // 100 xxxxx
    out.kind = SdoMessage::Kind::kAbort;
    out.abort_code = GetValue(frame);
  } else if (ccs == 2) {  // 010 xxxxx
    out.kind = SdoMessage::Kind::kUploadRequest;
  } else if (ccs == 1 && expedited) {  // 001 x nn 1 s
    out.kind = SdoMessage::Kind::kDownloadRequest;
    out.size = size_indicated ? static_cast<std::uint8_t>(4 - ((c >> 2) & 0x3)) : 4;  // s = 0: all 4 bytes
    out.value = Masked(GetValue(frame), out.size);
    out.size_indicated = size_indicated;
  } else if (ccs == 1) {  // 001 x xx 0 s: segmented
    out.kind = SdoMessage::Kind::kDownloadInitiateSegmented;
    out.size_indicated = size_indicated;
    out.value = out.size_indicated ? GetValue(frame) : 0;
  } else if (ccs == 0) {  // 000 t nnn c
    out.kind = SdoMessage::Kind::kDownloadSegmentRequest;
    DecodeSegment(frame, out);
  } else if (ccs == 3) {  // 011 t xxxx
    out.kind = SdoMessage::Kind::kUploadSegmentRequest;
    out.index = 0;
    out.subindex = 0;
    out.toggle = (c & 0x10) != 0;
  } else {
    out.kind = SdoMessage::Kind::kUnsupported;  // block transfers (ccs 5, 6), ccs 7
  }
  return true;
}

bool DecodeSdoResponse(const CanFrame& frame, SdoMessage& out) noexcept {
  if (!Common(frame, out)) return false;
  // As for requests: x bits and an n that is not valid are ignored.
  const std::uint8_t c = frame.data[0];
  const int scs = c >> 5;
  const bool expedited = (c & 0x02) != 0;
  const bool size_indicated = (c & 0x01) != 0;
  if (scs == 4) {  // 100 xxxxx
    out.kind = SdoMessage::Kind::kAbort;
    out.abort_code = GetValue(frame);
  } else if (scs == 3) {  // 011 xxxxx
    out.kind = SdoMessage::Kind::kDownloadResponse;
  } else if (scs == 2 && expedited) {  // 010 x nn 1 s
    out.kind = SdoMessage::Kind::kUploadResponse;
    out.size = size_indicated ? static_cast<std::uint8_t>(4 - ((c >> 2) & 0x3)) : 4;  // s = 0: all 4 bytes
    out.value = Masked(GetValue(frame), out.size);
    out.size_indicated = size_indicated;
  } else if (scs == 2) {  // 010 x xx 0 s: segmented
    out.kind = SdoMessage::Kind::kUploadInitiateSegmented;
    out.size_indicated = size_indicated;
    out.value = out.size_indicated ? GetValue(frame) : 0;
  } else if (scs == 0) {  // 000 t nnn c
    out.kind = SdoMessage::Kind::kUploadSegmentResponse;
    DecodeSegment(frame, out);
  } else if (scs == 1) {  // 001 t xxxx
    out.kind = SdoMessage::Kind::kDownloadSegmentResponse;
    out.index = 0;
    out.subindex = 0;
    out.toggle = (c & 0x10) != 0;
  } else {
    out.kind = SdoMessage::Kind::kUnsupported;  // block transfers (scs 5, 6), scs 7
  }
  return true;
}

}  // namespace teleop::fieldbus::canopen
