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

bool DecodeSdoRequest(const CanFrame& frame, SdoMessage& out) noexcept {
  if (!Common(frame, out)) return false;
  const std::uint8_t c = frame.data[0];
  const int ccs = c >> 5;
  if (c == 0x80) {
    out.kind = SdoMessage::Kind::kAbort;
    out.abort_code = GetValue(frame);
  } else if (ccs == 2 && (c & 0x1F) == 0) {
    out.kind = SdoMessage::Kind::kUploadRequest;
  } else if (ccs == 1 && (c & 0x13) == 0x03) {  // expedited, size indicated (bit 4 reserved 0)
    out.kind = SdoMessage::Kind::kDownloadRequest;
    out.size = static_cast<std::uint8_t>(4 - ((c >> 2) & 0x3));
    out.value = Masked(GetValue(frame), out.size);
  } else {
    out.kind = SdoMessage::Kind::kUnsupported;
  }
  return true;
}

bool DecodeSdoResponse(const CanFrame& frame, SdoMessage& out) noexcept {
  if (!Common(frame, out)) return false;
  const std::uint8_t c = frame.data[0];
  const int scs = c >> 5;
  if (c == 0x80) {
    out.kind = SdoMessage::Kind::kAbort;
    out.abort_code = GetValue(frame);
  } else if (scs == 3 && (c & 0x1F) == 0) {
    out.kind = SdoMessage::Kind::kDownloadResponse;
  } else if (scs == 2 && (c & 0x13) == 0x03) {
    out.kind = SdoMessage::Kind::kUploadResponse;
    out.size = static_cast<std::uint8_t>(4 - ((c >> 2) & 0x3));
    out.value = Masked(GetValue(frame), out.size);
  } else {
    out.kind = SdoMessage::Kind::kUnsupported;  // segmented (e = 0) or expedited without size
  }
  return true;
}

}  // namespace teleop::fieldbus::canopen
