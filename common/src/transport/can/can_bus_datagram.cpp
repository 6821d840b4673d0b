#include "teleop/transport/can_bus_datagram.hpp"

#include <cstring>

namespace teleop::transport::bus_datagram {

namespace {

void PutU32(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

std::uint32_t GetU32(const std::uint8_t* p) noexcept {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return v;
}

constexpr std::size_t kHeader = 5;

}  // namespace

std::size_t Encode(const Message& message, std::span<std::uint8_t> out) noexcept {
  std::size_t size = kHeader;
  switch (message.type) {
    case Type::kHello:
    case Type::kBye:
      break;
    case Type::kWelcome:
      size += 1;
      break;
    case Type::kFrame:
      size += 1 + 4 + 1 + message.frame.len;
      break;
    case Type::kControl:
      size += 1 + 4;
      break;
  }
  if (out.size() < size || message.frame.len > proto::can::kFdMaxDataBytes) return 0;
  std::uint8_t* p = out.data();
  PutU32(p, kMagic);
  p[4] = static_cast<std::uint8_t>(message.type);
  if (message.type == Type::kWelcome) p[5] = message.node;
  if (message.type == Type::kFrame) {
    const proto::can::CanFrame& f = message.frame;
    p[5] = static_cast<std::uint8_t>((f.extended ? 1u : 0u) | (f.fd ? 2u : 0u) | (f.brs ? 4u : 0u) |
                                     (f.error ? 8u : 0u) | (f.remote ? 16u : 0u));
    PutU32(p + 6, f.error ? f.error_class : f.id);
    p[10] = f.len;
    std::memcpy(p + 11, f.data.data(), f.len);
  }
  if (message.type == Type::kControl) {
    p[5] = static_cast<std::uint8_t>(message.action);
    PutU32(p + 6, message.argument);
  }
  return size;
}

bool Decode(std::span<const std::uint8_t> bytes, Message& out) noexcept {
  if (bytes.size() < kHeader || GetU32(bytes.data()) != kMagic) return false;
  const std::uint8_t* p = bytes.data();
  Message m{};
  m.type = static_cast<Type>(p[4]);
  switch (m.type) {
    case Type::kHello:
    case Type::kBye:
      if (bytes.size() != kHeader) return false;
      break;
    case Type::kWelcome:
      if (bytes.size() != kHeader + 1) return false;
      m.node = p[5];
      break;
    case Type::kControl:
      if (bytes.size() != kHeader + 5 || p[5] < 1 || p[5] > 3) return false;
      m.action = static_cast<Action>(p[5]);
      m.argument = GetU32(p + 6);
      break;
    case Type::kFrame: {
      if (bytes.size() < kHeader + 6) return false;
      proto::can::CanFrame& f = m.frame;
      const std::uint8_t flags = p[5];
      if ((flags & ~0x1Fu) != 0) return false;
      f.extended = (flags & 1u) != 0;
      f.fd = (flags & 2u) != 0;
      f.brs = (flags & 4u) != 0;
      f.error = (flags & 8u) != 0;
      f.remote = (flags & 16u) != 0;
      const std::uint32_t id = GetU32(p + 6);
      f.len = p[10];
      if (bytes.size() != kHeader + 6 + f.len) return false;
      if (f.fd ? !proto::can::IsValidFdLength(f.len) : f.len > proto::can::kClassicMaxDataBytes) return false;
      if (f.error) {
        f.error_class = id;
      } else {
        if (id > (f.extended ? proto::can::kMaxExtendedId : proto::can::kMaxStandardId)) return false;
        f.id = id;
      }
      std::memcpy(f.data.data(), p + 11, f.len);
      break;
    }
    default:
      return false;
  }
  out = m;
  return true;
}

}  // namespace teleop::transport::bus_datagram
