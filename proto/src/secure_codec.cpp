#include <algorithm>

#include "little_endian.hpp"
#include "teleop/proto/secure_message.hpp"

namespace teleop::proto {
namespace {

namespace sw = secure_wire;

using little_endian::GetU16;
using little_endian::GetU32;
using little_endian::GetU64;
using little_endian::PutU16;
using little_endian::PutU32;
using little_endian::PutU64;

bool ValidRole(std::uint8_t role) noexcept {
  return role == static_cast<std::uint8_t>(SenderRole::kMaster) ||
         role == static_cast<std::uint8_t>(SenderRole::kSlave);
}

void PutCommonHeader(std::uint8_t* p, SecureMessageType type, SenderRole sender) noexcept {
  PutU32(p + sw::kMagicOffset, wire::kMagic);
  p[sw::kVersionOffset] = kSecureProtocolVersion;
  p[sw::kTypeOffset] = static_cast<std::uint8_t>(type);
  p[sw::kSenderOffset] = static_cast<std::uint8_t>(sender);
  p[sw::kReservedOffset] = 0;
}

// Size ≥ 8, magic, version, type: the checks every version-2 decoder starts with.
DecodeStatus CheckCommonHeader(std::span<const std::uint8_t> bytes, SecureMessageType a, SecureMessageType b) noexcept {
  if (bytes.size() < sw::kCommonHeaderSize) return DecodeStatus::kTooShort;
  const std::uint8_t* p = bytes.data();
  if (GetU32(p + sw::kMagicOffset) != wire::kMagic) return DecodeStatus::kBadMagic;
  if (p[sw::kVersionOffset] != kSecureProtocolVersion) return DecodeStatus::kBadVersion;
  const std::uint8_t type = p[sw::kTypeOffset];
  if (type != static_cast<std::uint8_t>(a) && type != static_cast<std::uint8_t>(b)) return DecodeStatus::kBadType;
  return DecodeStatus::kOk;
}

DecodeStatus CheckExactSize(std::size_t size, std::size_t expected) noexcept {
  if (size < expected) return DecodeStatus::kTooShort;
  if (size > expected) return DecodeStatus::kBadLength;
  return DecodeStatus::kOk;
}

bool IsSamplePlaintextSize(std::size_t n) noexcept {
  for (int dof = 1; dof <= kMaxWireDof; ++dof) {
    if (n == EncodedSampleSize(dof, false) || n == EncodedSampleSize(dof, true)) return true;
  }
  return false;
}

}  // namespace

DatagramKind ClassifyDatagram(std::span<const std::uint8_t> bytes) noexcept {
  DatagramKind kind{};
  if (bytes.size() < sw::kTypeOffset + 1) return kind;
  if (GetU32(bytes.data() + sw::kMagicOffset) != wire::kMagic) {
    kind.status = DecodeStatus::kBadMagic;
    return kind;
  }
  kind.status = DecodeStatus::kOk;
  kind.version = bytes[sw::kVersionOffset];
  kind.type = bytes[sw::kTypeOffset];
  return kind;
}

std::size_t EncodeKeyExchange(const KeyExchangeMessage& message, std::span<std::uint8_t> out) noexcept {
  if (message.type != SecureMessageType::kHello && message.type != SecureMessageType::kWelcome) return 0;
  const bool hello = message.type == SecureMessageType::kHello;
  const std::size_t size = hello ? sw::kHelloSize : sw::kWelcomeSize;
  if (out.size() < size) return 0;
  if (!ValidRole(static_cast<std::uint8_t>(message.sender))) return 0;
  std::uint8_t* p = out.data();
  PutCommonHeader(p, message.type, message.sender);
  std::copy(message.ephemeral_key.begin(), message.ephemeral_key.end(), p + sw::kEphemeralKeyOffset);
  if (hello) PutU64(p + sw::kHelloTimestampOffset, message.timestamp);
  std::copy(message.tag.begin(), message.tag.end(), p + (hello ? sw::kHelloTagOffset : sw::kKeyExchangeTagOffset));
  return size;
}

std::size_t EncodeConfirm(const ConfirmMessage& message, std::span<std::uint8_t> out) noexcept {
  if (out.size() < sw::kConfirmSize) return 0;
  if (!ValidRole(static_cast<std::uint8_t>(message.sender))) return 0;
  std::uint8_t* p = out.data();
  PutCommonHeader(p, SecureMessageType::kConfirm, message.sender);
  PutU64(p + sw::kConfirmSessionIdOffset, message.session_id);
  std::copy(message.tag.begin(), message.tag.end(), p + sw::kConfirmTagOffset);
  return sw::kConfirmSize;
}

std::size_t EncodeSecureFrameHeader(const SecureFrameHeader& header, std::span<std::uint8_t> out) noexcept {
  if (out.size() < sw::kFrameHeaderSize) return 0;
  if (!ValidRole(static_cast<std::uint8_t>(header.sender))) return 0;
  if (!IsSamplePlaintextSize(header.sealed_length)) return 0;
  std::uint8_t* p = out.data();
  PutCommonHeader(p, SecureMessageType::kFrame, header.sender);
  PutU64(p + sw::kFrameSessionIdOffset, header.session_id);
  PutU64(p + sw::kFrameSequenceOffset, header.sequence);
  PutU16(p + sw::kFrameLengthOffset, header.sealed_length);
  PutU16(p + sw::kFrameReserved2Offset, 0);
  return sw::kFrameHeaderSize;
}

DecodeStatus DecodeKeyExchange(std::span<const std::uint8_t> bytes, KeyExchangeMessage& out) noexcept {
  DecodeStatus s = CheckCommonHeader(bytes, SecureMessageType::kHello, SecureMessageType::kWelcome);
  if (s != DecodeStatus::kOk) return s;
  const std::uint8_t* p = bytes.data();
  const bool hello = p[sw::kTypeOffset] == static_cast<std::uint8_t>(SecureMessageType::kHello);
  s = CheckExactSize(bytes.size(), hello ? sw::kHelloSize : sw::kWelcomeSize);
  if (s != DecodeStatus::kOk) return s;
  if (p[sw::kReservedOffset] != 0 || !ValidRole(p[sw::kSenderOffset])) return DecodeStatus::kOutOfRange;
  KeyExchangeMessage m{};
  m.type = static_cast<SecureMessageType>(p[sw::kTypeOffset]);
  m.sender = static_cast<SenderRole>(p[sw::kSenderOffset]);
  std::copy_n(p + sw::kEphemeralKeyOffset, kEphemeralKeyBytes, m.ephemeral_key.begin());
  if (hello) m.timestamp = GetU64(p + sw::kHelloTimestampOffset);
  std::copy_n(p + (hello ? sw::kHelloTagOffset : sw::kKeyExchangeTagOffset), kHandshakeTagBytes, m.tag.begin());
  out = m;
  return DecodeStatus::kOk;
}

DecodeStatus DecodeConfirm(std::span<const std::uint8_t> bytes, ConfirmMessage& out) noexcept {
  DecodeStatus s = CheckCommonHeader(bytes, SecureMessageType::kConfirm, SecureMessageType::kConfirm);
  if (s != DecodeStatus::kOk) return s;
  s = CheckExactSize(bytes.size(), sw::kConfirmSize);
  if (s != DecodeStatus::kOk) return s;
  const std::uint8_t* p = bytes.data();
  if (p[sw::kReservedOffset] != 0 || !ValidRole(p[sw::kSenderOffset])) return DecodeStatus::kOutOfRange;
  ConfirmMessage m{};
  m.sender = static_cast<SenderRole>(p[sw::kSenderOffset]);
  m.session_id = GetU64(p + sw::kConfirmSessionIdOffset);
  std::copy_n(p + sw::kConfirmTagOffset, kHandshakeTagBytes, m.tag.begin());
  out = m;
  return DecodeStatus::kOk;
}

DecodeStatus DecodeSecureFrame(std::span<const std::uint8_t> bytes, SecureFrameView& out) noexcept {
  const DecodeStatus s = CheckCommonHeader(bytes, SecureMessageType::kFrame, SecureMessageType::kFrame);
  if (s != DecodeStatus::kOk) return s;
  if (bytes.size() < sw::kFrameHeaderSize) return DecodeStatus::kTooShort;
  const std::uint8_t* p = bytes.data();
  const std::uint16_t sealed = GetU16(p + sw::kFrameLengthOffset);
  if (!IsSamplePlaintextSize(sealed)) return DecodeStatus::kBadLength;
  const DecodeStatus size_status = CheckExactSize(bytes.size(), sw::kFrameHeaderSize + sealed + kFrameTagBytes);
  if (size_status != DecodeStatus::kOk) return size_status;
  if (p[sw::kReservedOffset] != 0 || GetU16(p + sw::kFrameReserved2Offset) != 0 || !ValidRole(p[sw::kSenderOffset])) {
    return DecodeStatus::kOutOfRange;
  }
  SecureFrameView v{};
  v.header.sender = static_cast<SenderRole>(p[sw::kSenderOffset]);
  v.header.session_id = GetU64(p + sw::kFrameSessionIdOffset);
  v.header.sequence = GetU64(p + sw::kFrameSequenceOffset);
  v.header.sealed_length = sealed;
  v.associated_data = bytes.first(sw::kFrameHeaderSize);
  v.ciphertext = bytes.subspan(sw::kFrameHeaderSize, sealed);
  v.tag = bytes.subspan(sw::kFrameHeaderSize + sealed, kFrameTagBytes);
  out = v;
  return DecodeStatus::kOk;
}

std::array<std::uint8_t, 12> FrameNonce(SenderRole sender, std::uint64_t sequence) noexcept {
  std::array<std::uint8_t, 12> nonce{};
  PutU32(nonce.data(), static_cast<std::uint32_t>(sender));
  PutU64(nonce.data() + 4, sequence);
  return nonce;
}

}  // namespace teleop::proto
