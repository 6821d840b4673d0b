#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "teleop/proto/can/can_frame.hpp"

namespace teleop::transport {

/// The datagrams between teleop-canbus and its nodes on UDP (docs/can.md, "Emulated bus between processes").
/// Little-endian: u32 magic "TCB1", u8 type, then per type:
///   kHello    (node → bus)  nothing: attach the sender's address as a node (again: same node).
///   kWelcome  (bus → node)  u8 node index.
///   kFrame    (both ways)   u8 flags (bit 0 extended, 1 fd, 2 brs, 3 error, 4 remote), u32 id or error class,
///                           u8 len, len data bytes.
///   kControl  (node → bus)  u8 action (1 inject errors, 2 bus-off node, 3 restart node), u32 argument.
///   kBye      (node → bus)  nothing: detach.
namespace bus_datagram {
inline constexpr std::uint32_t kMagic = 0x31424354;  // "TCB1"
enum class Type : std::uint8_t { kHello = 1, kWelcome = 2, kFrame = 3, kControl = 4, kBye = 5 };
enum class Action : std::uint8_t { kInjectErrors = 1, kBusOff = 2, kRestart = 3 };
inline constexpr std::size_t kMaxSize = 4 + 1 + 1 + 4 + 1 + proto::can::kFdMaxDataBytes;

struct Message {
  Type type = Type::kHello;
  std::uint8_t node = 0;                  ///< kWelcome
  proto::can::CanFrame frame{};           ///< kFrame
  Action action = Action::kInjectErrors;  ///< kControl
  std::uint32_t argument = 0;             ///< kControl
};

/// Bytes written (0 when `out` is too small). No allocation.
std::size_t Encode(const Message& message, std::span<std::uint8_t> out) noexcept;
/// False for anything malformed (bad magic, type, length, FD length). No allocation.
bool Decode(std::span<const std::uint8_t> bytes, Message& out) noexcept;
}  // namespace bus_datagram

}  // namespace teleop::transport
