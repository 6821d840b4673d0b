#pragma once

// CANopen (CiA 301) network management frames: COB-IDs of the predefined connection set, NMT, SYNC, heartbeat
// and EMCY. Pure encode/decode on proto::can::CanFrame: no I/O, no allocation, no exceptions (docs/cia402.md).

#include <array>
#include <cstdint>

#include "teleop/proto/can/can_frame.hpp"

namespace teleop::fieldbus::canopen {

using proto::can::CanFrame;

/// Node-IDs 1..127; 0 addresses every node in an NMT command.
inline constexpr std::uint8_t kMaxNodeId = 127;
constexpr bool IsValidNodeId(int node_id) noexcept { return node_id >= 1 && node_id <= kMaxNodeId; }

/// Function codes of the predefined connection set (CiA 301): COB-ID = base + node-ID, except NMT
/// (0x000) and SYNC (0x080), which carry no node-ID.
namespace cob {
inline constexpr std::uint32_t kNmt = 0x000;
inline constexpr std::uint32_t kSync = 0x080;
inline constexpr std::uint32_t kEmcy = 0x080;  ///< + node-ID (1..127), so never 0x080 itself.
inline constexpr std::uint32_t kTpdo1 = 0x180;
inline constexpr std::uint32_t kRpdo1 = 0x200;
inline constexpr std::uint32_t kTpdo2 = 0x280;
inline constexpr std::uint32_t kRpdo2 = 0x300;
inline constexpr std::uint32_t kTpdo3 = 0x380;
inline constexpr std::uint32_t kRpdo3 = 0x400;
inline constexpr std::uint32_t kTpdo4 = 0x480;
inline constexpr std::uint32_t kRpdo4 = 0x500;
inline constexpr std::uint32_t kSdoTx = 0x580;  ///< Server → client (the drive's SDO responses).
inline constexpr std::uint32_t kSdoRx = 0x600;  ///< Client → server (the host's SDO requests).
inline constexpr std::uint32_t kHeartbeat = 0x700;
/// The default COB-ID of TPDO `n` (1..4) or RPDO `n` of `node_id`; 0 for n outside 1..4.
constexpr std::uint32_t DefaultTpdo(int n, std::uint8_t node_id) noexcept {
  return n >= 1 && n <= 4 ? kTpdo1 + 0x100u * static_cast<std::uint32_t>(n - 1) + node_id : 0u;
}
constexpr std::uint32_t DefaultRpdo(int n, std::uint8_t node_id) noexcept {
  return n >= 1 && n <= 4 ? kRpdo1 + 0x100u * static_cast<std::uint32_t>(n - 1) + node_id : 0u;
}
/// Bits of a PDO/SYNC/EMCY COB-ID entry (0x1400/0x1800 sub 1, 0x1005, 0x1014; CiA 301).
inline constexpr std::uint32_t kInvalidBit = 0x8000'0000u;  ///< PDO/EMCY does not exist / is not valid.
inline constexpr std::uint32_t kNoRtrBit = 0x4000'0000u;    ///< PDO: no RTR allowed. SYNC (0x1005): generate SYNC.
inline constexpr std::uint32_t kFrameBit = 0x2000'0000u;    ///< 29-bit identifier.
}  // namespace cob

// ---- NMT (CiA 301 NMT service): COB-ID 0x000, 2 bytes: command specifier, node-ID (0 = all) --------------------
enum class NmtCommand : std::uint8_t {
  kStart = 0x01,
  kStop = 0x02,
  kEnterPreOperational = 0x80,
  kResetNode = 0x81,
  kResetCommunication = 0x82,
};
const char* ToString(NmtCommand command) noexcept;
CanFrame EncodeNmt(NmtCommand command, std::uint8_t node_id) noexcept;
[[nodiscard]] bool DecodeNmt(const CanFrame& frame, NmtCommand& command, std::uint8_t& node_id) noexcept;

/// NMT states as a heartbeat reports them (CiA 301; bit 7 toggle not used with heartbeat).
enum class NmtState : std::uint8_t {
  kBootUp = 0x00,  ///< The boot-up message, sent once on entering pre-operational after initialisation.
  kStopped = 0x04,
  kOperational = 0x05,
  kPreOperational = 0x7F,
};
const char* ToString(NmtState state) noexcept;

// ---- Heartbeat (CiA 301 heartbeat protocol): COB-ID 0x700 + node-ID, 1 byte: NMT state
// ---------------------------------
CanFrame EncodeHeartbeat(std::uint8_t node_id, NmtState state) noexcept;
/// False unless COB-ID 0x701..0x77F, 1 byte, a known state.
[[nodiscard]] bool DecodeHeartbeat(const CanFrame& frame, std::uint8_t& node_id, NmtState& state) noexcept;

// ---- SYNC (CiA 301): COB-ID 0x080 (configurable in 0x1005), 0 bytes, or 1 byte counter 1..240 -------------
CanFrame EncodeSync(std::uint32_t cob_id = cob::kSync) noexcept;
CanFrame EncodeSync(std::uint32_t cob_id, std::uint8_t counter) noexcept;
/// True for a SYNC on `cob_id` (0 or 1 data bytes); `counter` is 0 when the SYNC carries none.
[[nodiscard]] bool DecodeSync(const CanFrame& frame, std::uint32_t cob_id, std::uint8_t& counter) noexcept;

// ---- EMCY (CiA 301): COB-ID 0x080 + node-ID, 8 bytes: error code (u16 LE), error register (0x1001),
//      5 manufacturer-specific bytes. An error code 0x0000 ("error reset / no error") reports recovery. ----------
struct Emergency {
  std::uint16_t error_code = 0;     ///< CiA 301 / CiA 402 emergency codes (0x2310 overcurrent, 0x8130 heartbeat...).
  std::uint8_t error_register = 0;  ///< Object 0x1001 bits (bit 0 generic, 1 current, 2 voltage, 3 temperature,
                                    ///< 4 communication, 5 device profile, 7 manufacturer).
  std::array<std::uint8_t, 5> manufacturer{};
};
CanFrame EncodeEmergency(std::uint8_t node_id, const Emergency& emergency) noexcept;
/// False unless COB-ID 0x081..0x0FF and 8 bytes.
[[nodiscard]] bool DecodeEmergency(const CanFrame& frame, std::uint8_t& node_id, Emergency& emergency) noexcept;
/// A short text for the common error codes ("overcurrent", "heartbeat/life guard error", ...), else "error".
const char* DescribeEmergencyCode(std::uint16_t error_code) noexcept;

/// Error codes used here (CiA 301 emergency error code table, CiA 402 ranges).
namespace emcy {
inline constexpr std::uint16_t kNoError = 0x0000;
inline constexpr std::uint16_t kGeneric = 0x1000;
inline constexpr std::uint16_t kOvercurrent = 0x2310;
inline constexpr std::uint16_t kDcLinkOvervoltage = 0x3210;
inline constexpr std::uint16_t kDeviceTemperature = 0x4210;
inline constexpr std::uint16_t kFollowingError = 0x8611;
inline constexpr std::uint16_t kHeartbeatError = 0x8130;  ///< Life guard / heartbeat consumer timeout.
inline constexpr std::uint16_t kPdoLength = 0x8210;       ///< PDO not processed due to length error.
}  // namespace emcy

}  // namespace teleop::fieldbus::canopen
