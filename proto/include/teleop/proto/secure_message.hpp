#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "teleop/proto/codec.hpp"
#include "teleop/proto/sample_message.hpp"

namespace teleop::proto {

// Version 2 of the wire format: the authenticated session (docs/protocol.md, "Authenticated session"). Version 1
// (the plain sample, codec.hpp) is unchanged and stays the insecure mode for benches. This file is the framing
// only: byte layout, explicit little-endian encode/decode, structural checks. The cryptography (key schedule,
// MACs, AEAD) lives in the session layer (teleop/transport/secure_session.hpp); proto/ holds no keys and calls no
// crypto library. No I/O, no allocation, no exceptions.

/// Version byte of every authenticated-session message.
inline constexpr std::uint8_t kSecureProtocolVersion = 2;

/// Message types of version 2. Values do not overlap version 1's kSample (1), so a type alone names the message.
enum class SecureMessageType : std::uint8_t {
  // 2 was the hello of the first release (no timestamp, 72 bytes): retired, decoded as kBadType (docs/protocol.md).
  kWelcome = 3,  ///< Responder → initiator: its ephemeral key, MAC under the PSK over hello + welcome.
  kConfirm = 4,  ///< Initiator → responder: the derived session id, MAC under the derived confirm key.
  kFrame = 5,    ///< Either way: one AEAD-sealed sample of an established session.
  /// Initiator (master) → responder: its ephemeral X25519 key and a timestamp that grows with every hello, MAC
  /// under the PSK. The responder refuses a hello not newer than the last one it answered (a replay).
  kHello = 6,
};

/// The retired hello type (first release, no timestamp): refused as kBadType, so a peer of that release is told
/// apart from a truncated hello.
inline constexpr std::uint8_t kRetiredHelloType = 2;

/// Sizes of the cryptographic fields (they equal libsodium's constants; the session layer static_asserts it).
inline constexpr std::size_t kEphemeralKeyBytes = 32;  ///< X25519 public key (crypto_scalarmult_BYTES).
inline constexpr std::size_t kHandshakeTagBytes = 32;  ///< HMAC-SHA-512-256 (crypto_auth_BYTES).
inline constexpr std::size_t kFrameTagBytes = 16;      ///< Poly1305 (crypto_aead_chacha20poly1305_ietf_ABYTES).

/// Byte layout of version-2 messages (docs/protocol.md, "Authenticated session"). All fields little-endian.
namespace secure_wire {
// Common header of every version-2 message (8 bytes): the first 6 bytes are laid out as in version 1, so any
// receiver can classify a datagram by magic, version and type.
inline constexpr std::size_t kMagicOffset = 0;     // u32 "TLOP", as version 1
inline constexpr std::size_t kVersionOffset = 4;   // u8 = 2
inline constexpr std::size_t kTypeOffset = 5;      // u8 SecureMessageType
inline constexpr std::size_t kSenderOffset = 6;    // u8 SenderRole
inline constexpr std::size_t kReservedOffset = 7;  // u8, sent as 0
inline constexpr std::size_t kCommonHeaderSize = 8;

// Hello: header, ephemeral key, timestamp, tag. Welcome: header, ephemeral key, tag.
inline constexpr std::size_t kEphemeralKeyOffset = 8;     // 32 bytes
inline constexpr std::size_t kHelloTimestampOffset = 40;  // u64, strictly increasing per initiator (ns)
inline constexpr std::size_t kHelloTagOffset = 48;
inline constexpr std::size_t kHelloSize = 80;             ///< The MAC covers bytes 0..47.
inline constexpr std::size_t kKeyExchangeTagOffset = 40;  ///< Welcome's tag.
inline constexpr std::size_t kKeyExchangeSize = 72;       ///< Welcome; its MAC covers hello ‖ welcome bytes 0..39.
inline constexpr std::size_t kWelcomeSize = kKeyExchangeSize;

// Confirm: header, session id, tag.
inline constexpr std::size_t kConfirmSessionIdOffset = 8;  // u64
inline constexpr std::size_t kConfirmTagOffset = 16;
inline constexpr std::size_t kConfirmSize = 48;  ///< The MAC covers bytes 0..15.

// Frame: header, session id, sequence, sealed length, reserved, then ciphertext + tag. Bytes 0..27 are the AEAD
// associated data (authenticated, sent in clear); the ciphertext is the version-1 encoding of the sample.
inline constexpr std::size_t kFrameSessionIdOffset = 8;   // u64
inline constexpr std::size_t kFrameSequenceOffset = 16;   // u64, +1 per frame per sender within a session
inline constexpr std::size_t kFrameLengthOffset = 24;     // u16, bytes of ciphertext (= plaintext)
inline constexpr std::size_t kFrameReserved2Offset = 26;  // u16, sent as 0
inline constexpr std::size_t kFrameHeaderSize = 28;
}  // namespace secure_wire

/// Smallest and largest sample plaintext a frame carries: the version-1 encoding of 1 DOF, and of kMaxWireDof DOF
/// with the energy block (EncodedSampleSize).
inline constexpr std::size_t kMinFramePlaintextBytes = 64;
inline constexpr std::size_t kMaxFramePlaintextBytes = kMaxEncodedSampleBytes;  // 520 (12 DOF with the energy block)
/// Largest frame: 28 + 520 + 16 = 564 bytes.
inline constexpr std::size_t kMaxSecureFrameSize =
    secure_wire::kFrameHeaderSize + kMaxFramePlaintextBytes + kFrameTagBytes;
/// Largest version-2 message of any type.
inline constexpr std::size_t kMaxSecureMessageSize = kMaxSecureFrameSize;

/// What a datagram claims to be, from its first 6 bytes (no other check).
struct DatagramKind {
  DecodeStatus status = DecodeStatus::kTooShort;  ///< kOk, kTooShort (< 6 bytes) or kBadMagic.
  std::uint8_t version = 0;
  std::uint8_t type = 0;
};
[[nodiscard]] DatagramKind ClassifyDatagram(std::span<const std::uint8_t> bytes) noexcept;

/// Hello (kHelloSize bytes, with a timestamp) or welcome (kWelcomeSize, none), told apart by `type`.
struct KeyExchangeMessage {
  SecureMessageType type = SecureMessageType::kHello;
  SenderRole sender = SenderRole::kMaster;
  std::array<std::uint8_t, kEphemeralKeyBytes> ephemeral_key{};
  std::uint64_t timestamp = 0;  ///< Hello only (welcome: not on the wire, decoded as 0).
  std::array<std::uint8_t, kHandshakeTagBytes> tag{};
};

struct ConfirmMessage {
  SenderRole sender = SenderRole::kMaster;
  std::uint64_t session_id = 0;
  std::array<std::uint8_t, kHandshakeTagBytes> tag{};
};

/// The clear part of a frame.
struct SecureFrameHeader {
  SenderRole sender = SenderRole::kMaster;
  std::uint64_t session_id = 0;
  std::uint64_t sequence = 0;
  std::uint16_t sealed_length = 0;  ///< Ciphertext bytes (the tag follows them).
};

/// A decoded frame: its header and views into the datagram (valid while the datagram's bytes are).
struct SecureFrameView {
  SecureFrameHeader header{};
  std::span<const std::uint8_t> associated_data{};  ///< Bytes 0..27.
  std::span<const std::uint8_t> ciphertext{};       ///< header.sealed_length bytes.
  std::span<const std::uint8_t> tag{};              ///< kFrameTagBytes.
};

// Encoders return the bytes written (0 when `out` is too small or the message invalid). They write the tag field
// as given: the session layer computes it over the bytes the encoder wrote and fills it in.
[[nodiscard]] std::size_t EncodeKeyExchange(const KeyExchangeMessage& message, std::span<std::uint8_t> out) noexcept;
[[nodiscard]] std::size_t EncodeConfirm(const ConfirmMessage& message, std::span<std::uint8_t> out) noexcept;
/// Writes the 28-byte header; the caller writes sealed_length bytes of ciphertext and the tag after it.
[[nodiscard]] std::size_t EncodeSecureFrameHeader(const SecureFrameHeader& header,
                                                  std::span<std::uint8_t> out) noexcept;

// Decoders check, in this order: size ≥ 8, magic, version 2, type, exact size for the type (frames: the length
// field, then the size), reserved bytes 0 and role 0/1 (kOutOfRange). `out` is written only on kOk.
[[nodiscard]] DecodeStatus DecodeKeyExchange(std::span<const std::uint8_t> bytes, KeyExchangeMessage& out) noexcept;
[[nodiscard]] DecodeStatus DecodeConfirm(std::span<const std::uint8_t> bytes, ConfirmMessage& out) noexcept;
/// A frame's sealed length must be a version-1 sample size for some dof (64 + 24·k, or 80 + 40·k with the energy
/// block, k = 0..5).
[[nodiscard]] DecodeStatus DecodeSecureFrame(std::span<const std::uint8_t> bytes, SecureFrameView& out) noexcept;

/// The 12-byte AEAD nonce of a frame: u32 sender role, u64 sequence (little-endian). Unique per key because each
/// direction has its own key and a sender never reuses a sequence within a session.
std::array<std::uint8_t, 12> FrameNonce(SenderRole sender, std::uint64_t sequence) noexcept;

}  // namespace teleop::proto
