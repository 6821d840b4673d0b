#pragma once

// The outcomes of SecureSession::Receive, apart from the session itself so that the link counters (link.hpp) can
// count them without pulling in the session. ToString is defined with the session (library transport_secure).

#include <cstddef>
#include <cstdint>

namespace teleop::transport {

/// What Receive() did with one datagram. Every datagram is exactly one of these, and one counter.
enum class SecureReceiveStatus : std::uint8_t {
  kSample = 0,            ///< An authenticated, fresh, plausible sample: `sample` written.
  kHandshake,             ///< A valid handshake message; `reply_size` bytes to send may be in `reply`.
  kRateLimited,           ///< Dropped by the datagram bucket, before parsing.
  kHandshakeRateLimited,  ///< A hello/welcome over the handshake bucket, before any crypto.
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
  kCount,
};
const char* ToString(SecureReceiveStatus status) noexcept;

inline constexpr std::size_t kSecureStatusCount = static_cast<std::size_t>(SecureReceiveStatus::kCount);

}  // namespace teleop::transport
