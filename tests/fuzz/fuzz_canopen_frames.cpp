// libFuzzer harness: the CANopen / CiA 402 frame decoders of the fieldbus drivers (common/src/fieldbus:
// canopen_frames.cpp NMT, heartbeat, SYNC, EMCY; canopen_sdo.cpp expedited SDO requests and responses;
// canopen_pdo.cpp PDO unpacking; cia402_state_machine.cpp the statusword decoder and the controlword sequence).
// The first 9 input bytes pick a PDO mapping (number, COB-ID, transmission type, up to 8 entries of 8/16/32 bits);
// the rest is a stream of frames, each: a control byte (bit 0 extended, 1 FD, 2 remote, 3 error), two identifier
// bytes (LE, masked to 11 or 29 bits), a length byte, then that many data bytes. Every decoder sees every frame.
// Properties: no crash or UB; a decoder that accepts a frame gives fields in their documented ranges; what an
// accepted frame decodes to encodes back to a frame that decodes to the same fields; every status and text is
// valid; the drive state machine never leaves its state set.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "fuzz_check.hpp"
#include "teleop/fieldbus/canopen_frames.hpp"
#include "teleop/fieldbus/canopen_pdo.hpp"
#include "teleop/fieldbus/canopen_sdo.hpp"
#include "teleop/fieldbus/cia402_state_machine.hpp"

namespace {

using teleop::proto::can::CanFrame;
namespace canopen = teleop::fieldbus::canopen;
namespace cia402 = teleop::fieldbus::cia402;

/// One direction of expedited SDO: a frame `decode` accepts as `data_kind` has a 1..4-byte value within its size and
/// re-encodes (with `encode`) to a frame that decodes the same; an abort has a text.
template <typename Decode, typename Encode>
void CheckSdoDirection(const CanFrame& frame, canopen::SdoMessage::Kind data_kind, Decode decode, Encode encode) {
  canopen::SdoMessage m{};
  if (!decode(frame, m)) return;
  TELEOP_FUZZ_CHECK(!frame.extended && frame.len == 8);
  if (m.kind == data_kind) {
    TELEOP_FUZZ_CHECK(m.size >= 1 && m.size <= 4);
    TELEOP_FUZZ_CHECK(m.size == 4 || m.value < (1u << (8 * m.size)));
    const auto node = static_cast<std::uint8_t>(frame.id & 0x7F);
    canopen::SdoMessage again{};
    TELEOP_FUZZ_CHECK(decode(encode(node, m.index, m.subindex, m.value, m.size), again));
    TELEOP_FUZZ_CHECK(again.kind == m.kind && again.index == m.index && again.subindex == m.subindex &&
                      again.value == m.value && again.size == m.size);
  }
  if (m.kind == canopen::SdoMessage::Kind::kAbort) TELEOP_FUZZ_CHECK(canopen::DescribeSdoAbort(m.abort_code));
}

void CheckSdo(const CanFrame& frame) {
  CheckSdoDirection(frame, canopen::SdoMessage::Kind::kDownloadRequest, canopen::DecodeSdoRequest,
                    canopen::EncodeSdoDownloadRequest);
  CheckSdoDirection(frame, canopen::SdoMessage::Kind::kUploadResponse, canopen::DecodeSdoResponse,
                    canopen::EncodeSdoUploadResponse);
}

void CheckNmtHeartbeatSyncEmcy(const CanFrame& frame) {
  canopen::NmtCommand command{};
  std::uint8_t node = 0;
  if (canopen::DecodeNmt(frame, command, node)) {
    TELEOP_FUZZ_CHECK(canopen::ToString(command) != nullptr);
    canopen::NmtCommand c2{};
    std::uint8_t n2 = 0;
    TELEOP_FUZZ_CHECK(canopen::DecodeNmt(canopen::EncodeNmt(command, node), c2, n2) && c2 == command && n2 == node);
  }
  canopen::NmtState state{};
  if (canopen::DecodeHeartbeat(frame, node, state)) {
    TELEOP_FUZZ_CHECK(canopen::IsValidNodeId(node));
    TELEOP_FUZZ_CHECK(canopen::ToString(state) != nullptr);
    canopen::NmtState s2{};
    std::uint8_t n2 = 0;
    TELEOP_FUZZ_CHECK(canopen::DecodeHeartbeat(canopen::EncodeHeartbeat(node, state), n2, s2) && s2 == state &&
                      n2 == node);
  }
  std::uint8_t counter = 0;
  if (canopen::DecodeSync(frame, canopen::cob::kSync, counter)) TELEOP_FUZZ_CHECK(frame.len <= 1);
  canopen::Emergency emcy{};
  if (canopen::DecodeEmergency(frame, node, emcy)) {
    TELEOP_FUZZ_CHECK(canopen::IsValidNodeId(node));
    TELEOP_FUZZ_CHECK(canopen::DescribeEmergencyCode(emcy.error_code) != nullptr);
    canopen::Emergency e2{};
    std::uint8_t n2 = 0;
    TELEOP_FUZZ_CHECK(canopen::DecodeEmergency(canopen::EncodeEmergency(node, emcy), n2, e2) && n2 == node &&
                      e2.error_code == emcy.error_code && e2.error_register == emcy.error_register &&
                      e2.manufacturer == emcy.manufacturer);
  }
}

void CheckPdo(const canopen::PdoMapping& mapping, bool mapping_ok, const CanFrame& frame) {
  std::array<std::uint32_t, canopen::kMaxPdoEntries> values{};
  const std::span<std::uint32_t> out(values.data(), static_cast<std::size_t>(mapping.entry_count));
  if (!mapping_ok || !canopen::UnpackPdo(mapping, frame, out)) return;
  TELEOP_FUZZ_CHECK(frame.len == canopen::PdoLength(mapping));
  for (int i = 0; i < mapping.entry_count; ++i) {
    const int bits = mapping.entries[static_cast<std::size_t>(i)].bits;
    TELEOP_FUZZ_CHECK(bits == 32 || values[static_cast<std::size_t>(i)] < (1u << bits));
  }
  // Packing what was unpacked gives the frame's data back.
  CanFrame packed{};
  TELEOP_FUZZ_CHECK(canopen::PackPdo(mapping, frame.id, out, packed));
  TELEOP_FUZZ_CHECK(packed.len == frame.len && std::memcmp(packed.data.data(), frame.data.data(), frame.len) == 0);
}

void CheckStatusword(std::uint16_t statusword, cia402::DriveStateMachine& drive) {
  const cia402::DriveState state = cia402::DecodeStatusword(statusword);
  TELEOP_FUZZ_CHECK(cia402::ToString(state) != nullptr);
  const std::uint16_t controlword = cia402::ControlwordTowardOperationEnabled(state, statusword);
  const int transition = drive.Apply(controlword, (statusword & 1) != 0);
  TELEOP_FUZZ_CHECK(transition >= 0 && transition <= 16);
  TELEOP_FUZZ_CHECK(cia402::ToString(drive.state()) != nullptr);
  // The drive's own statusword decodes to the state it is in.
  TELEOP_FUZZ_CHECK(cia402::DecodeStatusword(drive.Statusword()) == drive.state());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 9) return 0;
  canopen::PdoMapping mapping{};
  mapping.number = 1 + data[0] % 4;
  mapping.entry_count = 1 + (data[0] >> 2) % canopen::kMaxPdoEntries;
  mapping.transmission_type = data[1];
  mapping.cob_id = (data[0] & 0x80) != 0 ? 0u : 0x180u + data[2];
  for (int i = 0; i < mapping.entry_count; ++i) {
    const std::uint8_t b = data[1 + i];
    mapping.entries[static_cast<std::size_t>(i)] = {static_cast<std::uint16_t>(0x6000 + b), b,
                                                    static_cast<std::uint8_t>(8u << (b % 3))};
  }
  const canopen::PdoMappingStatus mapping_status = canopen::CheckPdoMapping(mapping);
  TELEOP_FUZZ_CHECK(canopen::ToString(mapping_status) != nullptr);
  const bool mapping_ok = mapping_status == canopen::PdoMappingStatus::kOk;
  if (mapping_ok) TELEOP_FUZZ_CHECK(canopen::PdoLength(mapping) >= 1 && canopen::PdoLength(mapping) <= 8);

  cia402::DriveStateMachine drive;
  drive.FinishInitialisation();
  std::size_t i = 9;
  while (i + 4 <= size) {
    const std::uint8_t control = data[i];
    CanFrame frame{};
    frame.extended = (control & 0x01) != 0;
    frame.fd = (control & 0x02) != 0;
    frame.remote = (control & 0x04) != 0;
    frame.error = (control & 0x08) != 0;
    frame.id = (std::uint32_t{data[i + 1]} | std::uint32_t{data[i + 2]} << 8) &
               (frame.extended ? teleop::proto::can::kMaxExtendedId : teleop::proto::can::kMaxStandardId);
    const std::size_t len = data[i + 3] % (teleop::proto::can::kFdMaxDataBytes + 1);
    frame.len = static_cast<std::uint8_t>(len);
    i += 4;
    for (std::size_t k = 0; k < len && i < size; ++k, ++i) frame.data[k] = data[i];
    CheckSdo(frame);
    CheckNmtHeartbeatSyncEmcy(frame);
    CheckPdo(mapping, mapping_ok, frame);
    if ((control & 0x10) != 0) drive.Fault();
    if ((control & 0x20) != 0) drive.FaultReactionDone();
    CheckStatusword(static_cast<std::uint16_t>(frame.data[0] | frame.data[1] << 8), drive);
  }
  return 0;
}
