#pragma once

// The outcomes of SecureSession::Receive, apart from the session itself so that the link counters (link.hpp) can
// count them without pulling in the session. ToString is defined with the session (library transport_secure).

#include <cstddef>
#include <cstdint>

namespace teleop::transport {

/// What Receive() did with one datagram. Every datagram is exactly one of these, and one counter.
enum class SecureReceiveStatus : std::uint8_t {
  kSample = 0,  ///< An authenticated, fresh, plausible sample: `sample` written.
  kHandshake,   ///< A valid handshake message; `reply_size` bytes to send may be in `reply`.
  /// A rejected datagram beyond the rejection bucket: counted here instead of under its own reason (a flood).
  /// Authentic frames and handshake messages never take a token and are never counted here.
  kRateLimited,
  kHandshakeRateLimited,  ///< An authentic, fresh hello/welcome over the handshake bucket, before its X25519.
  kInsecure,              ///< A version-1 (unauthenticated) datagram: ignored, whatever its flags say.
  kMalformed,             ///< Not a version-2 message of a known type and size (DecodeStatus != kOk).
  kWrongSender,           ///< Carries our own role, or a role that may not send this type.
  kUnexpectedHandshake,   ///< A handshake message that does not fit our role or state (e.g. welcome not awaited).
  kBadHandshakeTag,       ///< Handshake MAC wrong (wrong PSK or forged), or a low-order ephemeral key.
  kNoSession,             ///< A frame while no session exists: a new handshake is needed.
  kWrongSession,          ///< A frame of another (older, or forged) session id.
  kReplayed,              ///< Sequence already accepted in this session.
  kTooOld,                ///< Sequence behind the replay window.
  kBadTag,                ///< AEAD verification failed: forged, corrupted, truncated inside, or flipped bits.
  kBadPlaintext,          ///< Authentic, but the inner sample does not decode or disagrees with the frame/config.
  kImplausible,           ///< Authentic and valid, beyond the plausibility bounds.
  /// An authentic hello whose timestamp is not newer than the last one answered, and not a byte-identical copy of
  /// it: a replay of an older hello. Refused before any X25519; no reply.
  kStaleHandshake,
  kCount,
};
const char* ToString(SecureReceiveStatus status) noexcept;

inline constexpr std::size_t kSecureStatusCount = static_cast<std::size_t>(SecureReceiveStatus::kCount);

}  // namespace teleop::transport
