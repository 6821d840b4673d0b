#pragma once

// SDO frames (CiA 301 §7.2.4.3, SDO protocols): expedited transfers (1..4 bytes in one frame each way) and segmented
// transfers (§7.2.4.3.3-6: initiate with the size, then segments of up to 7 bytes with an alternating toggle bit).
// Block transfers are not implemented: a block command decodes as kUnsupported and is aborted (0x05040001).
// Pure encode/decode: no I/O, no allocation, no exceptions.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "teleop/fieldbus/canopen_frames.hpp"

namespace teleop::fieldbus::canopen {

/// SDO abort codes (CiA 301, "SDO abort codes").
namespace sdo_abort {
inline constexpr std::uint32_t kToggleBit = 0x0503'0000;
inline constexpr std::uint32_t kTimeout = 0x0504'0000;
inline constexpr std::uint32_t kBadCommand = 0x0504'0001;
inline constexpr std::uint32_t kOutOfMemory = 0x0504'0005;
inline constexpr std::uint32_t kUnsupportedAccess = 0x0601'0000;
inline constexpr std::uint32_t kWriteOnly = 0x0601'0001;
inline constexpr std::uint32_t kReadOnly = 0x0601'0002;
inline constexpr std::uint32_t kNoObject = 0x0602'0000;
inline constexpr std::uint32_t kNotMappable = 0x0604'0041;
inline constexpr std::uint32_t kPdoTooLong = 0x0604'0042;
inline constexpr std::uint32_t kIncompatibleParameter = 0x0604'0043;
inline constexpr std::uint32_t kHardwareError = 0x0606'0000;
inline constexpr std::uint32_t kLengthMismatch = 0x0607'0010;
inline constexpr std::uint32_t kLengthTooHigh = 0x0607'0012;
inline constexpr std::uint32_t kLengthTooLow = 0x0607'0013;
inline constexpr std::uint32_t kNoSubindex = 0x0609'0011;
inline constexpr std::uint32_t kValueRange = 0x0609'0030;
inline constexpr std::uint32_t kValueTooHigh = 0x0609'0031;
inline constexpr std::uint32_t kValueTooLow = 0x0609'0032;
inline constexpr std::uint32_t kNoData = 0x0800'0024;  ///< No data available (e.g. an empty error history entry).
inline constexpr std::uint32_t kGeneral = 0x0800'0000;
inline constexpr std::uint32_t kCannotStore = 0x0800'0020;
inline constexpr std::uint32_t kCannotStoreLocal = 0x0800'0021;
inline constexpr std::uint32_t kCannotStoreState = 0x0800'0022;  ///< Because of the present device state.
}  // namespace sdo_abort
/// The standard's text for an abort code ("Object does not exist in the object dictionary"), or
/// "unknown abort code" for anything not in that table.
const char* DescribeSdoAbort(std::uint32_t code) noexcept;

/// One expedited SDO frame, decoded. Byte 0 is the command specifier (ccs/scs in bits 7..5), bytes 1..2 the index
/// (LE), byte 3 the subindex, bytes 4..7 the data (LE) or the abort code.
struct SdoMessage {
  enum class Kind : std::uint8_t {
    kUploadRequest,     ///< Client: ccs 2 (0x40).
    kDownloadRequest,   ///< Client: ccs 1, expedited, size indicated (0x2F/0x2B/0x27/0x23 for 1/2/3/4 bytes).
    kUploadResponse,    ///< Server: scs 2, expedited, size indicated (0x4F/0x4B/0x47/0x43).
    kDownloadResponse,  ///< Server: scs 3 (0x60).
    kAbort,             ///< Either side: cs 4 (0x80).
    kUnsupported,       ///< Anything else (block transfers, reserved specifiers): refused by the caller.
    // Segmented transfer (CiA 301 §7.2.4.3.3-6). `size_indicated` and `value` (the size) for the initiates;
    // `toggle`, `last` (c) and `segment[0..segment_size)` for the segments (bytes 1..7; no index there: 0).
    kDownloadInitiateSegmented,  ///< Client: ccs 1, e = 0 (0x21 with the size in bytes 4..7, 0x20 without).
    kUploadInitiateSegmented,    ///< Server: scs 2, e = 0 (0x41 with the size in bytes 4..7, 0x40 without).
    kDownloadSegmentRequest,     ///< Client: ccs 0, t, n (bytes not holding data), c (last segment).
    kDownloadSegmentResponse,    ///< Server: scs 1, t (0x20 / 0x30).
    kUploadSegmentRequest,       ///< Client: ccs 3, t (0x60 / 0x70).
    kUploadSegmentResponse,      ///< Server: scs 0, t, n, c.
  };
  Kind kind = Kind::kUnsupported;
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::uint32_t value = 0;  ///< Data (zero-extended) of a download request or upload response.
  std::uint8_t size = 0;    ///< Data bytes 1..4 (0 for requests without data and responses without data).
  std::uint32_t abort_code = 0;
  bool size_indicated = false;  ///< Initiates: s = 1 (for an expedited transfer with s = 0, size is 4).
  bool toggle = false;          ///< Segments: t.
  bool last = false;            ///< Segments: c = 1, no more segments follow.
  std::uint8_t segment_size = 0;
  std::array<std::uint8_t, 7> segment{};
};

/// Data bytes in one SDO segment (bytes 1..7 of the frame).
inline constexpr std::size_t kSdoSegmentBytes = 7;

// Client → server on COB-ID 0x600 + node-ID.
CanFrame EncodeSdoUploadRequest(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex) noexcept;
/// `size` 1..4 bytes of `value` (LE); a size outside 1..4 is clamped into it.
CanFrame EncodeSdoDownloadRequest(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex, std::uint32_t value,
                                  std::uint8_t size) noexcept;
// Server → client on COB-ID 0x580 + node-ID.
CanFrame EncodeSdoUploadResponse(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex, std::uint32_t value,
                                 std::uint8_t size) noexcept;
CanFrame EncodeSdoDownloadResponse(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex) noexcept;
/// An abort on `cob_id` (0x580 + node from a server, 0x600 + node from a client).
CanFrame EncodeSdoAbort(std::uint32_t cob_id, std::uint16_t index, std::uint8_t subindex,
                        std::uint32_t abort_code) noexcept;

// Segmented transfers (CiA 301 §7.2.4.3.3-6). The toggle bit is bit 4 of byte 0; the first segment has t = 0 and
// each following one the other value; a response repeats its request's t. `data` of a segment: 0..7 bytes (more is
// cut to 7); n = 7 - size is coded in bits 3..1, c (the last segment) in bit 0.
/// Client: initiate a segmented download of `size` bytes (size indicated: 0x21, the size in bytes 4..7).
CanFrame EncodeSdoInitiateDownloadSegmented(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex,
                                            std::uint32_t size) noexcept;
/// Server: the answer to an upload request that continues segmented (size indicated: 0x41, the size in bytes 4..7).
CanFrame EncodeSdoInitiateUploadSegmented(std::uint8_t node_id, std::uint16_t index, std::uint8_t subindex,
                                          std::uint32_t size) noexcept;
/// Client: one download segment (ccs 0).
CanFrame EncodeSdoDownloadSegment(std::uint8_t node_id, bool toggle, std::span<const std::uint8_t> data,
                                  bool last) noexcept;
/// Server: the confirmation of a download segment (scs 1): 0x20 / 0x30.
CanFrame EncodeSdoDownloadSegmentResponse(std::uint8_t node_id, bool toggle) noexcept;
/// Client: request the next upload segment (ccs 3): 0x60 / 0x70.
CanFrame EncodeSdoUploadSegmentRequest(std::uint8_t node_id, bool toggle) noexcept;
/// Server: one upload segment (scs 0).
CanFrame EncodeSdoUploadSegment(std::uint8_t node_id, bool toggle, std::span<const std::uint8_t> data,
                                bool last) noexcept;

/// Decodes a request (client → server) read on 0x600 + node-ID. False unless 8 bytes, standard identifier.
[[nodiscard]] bool DecodeSdoRequest(const CanFrame& frame, SdoMessage& out) noexcept;
/// Decodes a response (server → client) read on 0x580 + node-ID. False unless 8 bytes, standard identifier.
[[nodiscard]] bool DecodeSdoResponse(const CanFrame& frame, SdoMessage& out) noexcept;

}  // namespace teleop::fieldbus::canopen
