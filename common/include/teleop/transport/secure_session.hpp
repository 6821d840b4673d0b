#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "teleop/proto/sample_message.hpp"
#include "teleop/proto/secure_message.hpp"
#include "teleop/transport/secure_key_file.hpp"
#include "teleop/transport/secure_rate_limiter.hpp"
#include "teleop/transport/secure_replay_window.hpp"
#include "teleop/transport/secure_status.hpp"  // IWYU pragma: export

namespace teleop::transport {

// The authenticated session of protocol version 2 (docs/protocol.md, "Authenticated session"; docs/security.md).
// Pure state machine over bytes: the caller owns the socket, passes every inbound datagram to Receive() with its
// monotonic time, sends what Receive() or BeginHandshake() write into the caller's buffer, and seals each outgoing
// sample with Seal(). Receive() and Seal() are real-time safe: no allocation, lock, exception, I/O or logging;
// every buffer is a member sized at construction. Not thread-safe: one thread (the control loop) owns it.
//
// Handshake (3 messages; the master initiates):
//   hello   M→S  e_M,                      MAC(k_hs, hello[0..40))
//   welcome S→M  e_S,                      MAC(k_hs, hello ‖ welcome[0..40))
//   confirm M→S  session id,               MAC(k_confirm, confirm[0..16))
// k_hs = KDF(PSK, 1, "TLOPhsk1"); secret = BLAKE2b-256(key = PSK, X25519(e, e') ‖ hello ‖ welcome);
// k_M→S, k_S→M, k_confirm, session id = KDF(secret, 1..4, "TLOPsess"). Frames: ChaCha20-Poly1305 (IETF) with the
// 28-byte clear header as associated data and FrameNonce(sender, sequence) as nonce.

/// Configuration of one end. Set-up values; the constructor checks them (teleop::Error).
struct SecureSessionConfig {
  proto::SenderRole role = proto::SenderRole::kMaster;  ///< The master initiates the handshake.
  int dof = 1;                                          ///< Samples must carry exactly this many DOF.
  /// Plausibility of accepted samples: a peer sample whose velocity, force, or position step since the previous
  /// newest sample (over the sender's clock) exceeds these is rejected (counted `implausible`), like a lost sample.
  double max_speed_m_per_s = 2.0;
  double max_force_N = 100.0;
  double position_slack_m = 1e-3;  ///< Allowed on top of max_speed · Δt (quantization, estimator noise).
  /// Inbound rate limit before any parsing: a token bucket over all datagrams, and a stricter one over hello and
  /// welcome (each costs an X25519 operation, ~50 µs). Defaults allow 4 kHz with bursts.
  double max_datagrams_per_s = 20000.0;
  double datagram_burst = 512.0;
  double max_handshakes_per_s = 20.0;
  double handshake_burst = 4.0;
};

// SecureReceiveStatus (what Receive() did with one datagram): teleop/transport/secure_status.hpp.

struct SecureReceiveResult {
  SecureReceiveStatus status = SecureReceiveStatus::kMalformed;
  std::size_t reply_size = 0;  ///< Bytes written to `reply`, to send to the peer now (welcome or confirm).
  bool newest = false;         ///< kSample only: newer than every sample accepted before in this session.
};

/// One counter per SecureReceiveStatus value, plus events. received == Σ by_status.
struct SecureCounters {
  std::uint64_t received = 0;
  std::array<std::uint64_t, static_cast<std::size_t>(SecureReceiveStatus::kCount)> by_status{};
  std::uint64_t sessions_established = 0;  ///< Handshakes completed (this end switched to a new session).
  std::uint64_t handshakes_started = 0;    ///< Hellos sent (initiator) or answered (responder).
  std::uint64_t sealed = 0;                ///< Frames produced by Seal().
  std::uint64_t seal_refused = 0;          ///< Seal() calls that produced nothing (no session, bad sample).

  std::uint64_t count(SecureReceiveStatus s) const noexcept { return by_status[static_cast<std::size_t>(s)]; }
  /// Every datagram that was neither a sample nor a handshake message.
  std::uint64_t rejected() const noexcept;
};

enum class SecureSessionState : std::uint8_t {
  kNoSession,    ///< No keys: frames cannot be sealed or opened.
  kHandshaking,  ///< Initiator: hello sent, no session yet. Responder: welcome sent, awaiting confirm.
  kEstablished,  ///< Keys agreed and confirmed; Seal() works. (A re-handshake may run beside it.)
};

class SecureSession {
 public:
  /// Throws teleop::Error when libsodium cannot initialise or the config is invalid.
  SecureSession(const SecureSessionConfig& config, const PreSharedKey& key);
  ~SecureSession();
  SecureSession(const SecureSession&) = delete;
  SecureSession& operator=(const SecureSession&) = delete;

  /// Initiator (master) only: writes a hello with a fresh ephemeral key into `out` (≥ 72 bytes) and returns its
  /// size (0 for a responder or a short buffer). Call again to retry; a running session keeps working until the
  /// new handshake completes (that is also how to re-key). Not for the cycle: it draws randomness and does X25519.
  [[nodiscard]] std::size_t BeginHandshake(std::span<std::uint8_t> out) noexcept;

  /// Processes one inbound datagram received at `now_ns`. `reply` needs ≥ proto::kMaxSecureMessageSize bytes for
  /// handshake replies. `sample` is written only on kSample. Counts the outcome.
  [[nodiscard]] SecureReceiveResult Receive(std::span<const std::uint8_t> datagram, std::uint64_t now_ns,
                                            std::span<std::uint8_t> reply, proto::SampleMessage& sample) noexcept;

  /// Seals `sample` (sender must be our role, dof the configured one) as the next frame of the established session
  /// into `out` (≥ proto::kMaxSecureFrameSize); returns its size, 0 when there is no session or the sample is
  /// refused. The inner sample's sequence is replaced by the low 32 bits of the frame sequence.
  [[nodiscard]] std::size_t Seal(const proto::SampleMessage& sample, std::span<std::uint8_t> out) noexcept;

  SecureSessionState state() const noexcept;
  /// Id of the established session (0: none). Changes exactly when a handshake completes: the node resets its
  /// sequence tracker and re-aligns then.
  std::uint64_t session_id() const noexcept { return current_.active ? current_.id : 0; }
  const SecureCounters& counters() const noexcept { return counters_; }
  const SecureSessionConfig& config() const noexcept { return config_; }

 private:
  static constexpr std::size_t kKeyBytes = 32;
  using Key = std::array<std::uint8_t, kKeyBytes>;

  struct Keys {
    bool active = false;
    std::uint64_t id = 0;
    Key tx{};
    Key rx{};
    Key confirm{};
    std::uint64_t next_tx_sequence = 0;
    SecureReplayWindow window{};
    bool have_newest = false;
    proto::SampleMessage newest{};  ///< Newest accepted sample (plausibility of the next position step).
  };

  SecureReceiveResult Count(SecureReceiveResult result) noexcept;
  SecureReceiveResult OnHello(std::span<const std::uint8_t> datagram, std::span<std::uint8_t> reply) noexcept;
  SecureReceiveResult OnWelcome(std::span<const std::uint8_t> datagram, std::span<std::uint8_t> reply) noexcept;
  SecureReceiveResult OnConfirm(std::span<const std::uint8_t> datagram) noexcept;
  SecureReceiveResult OnFrame(std::span<const std::uint8_t> datagram, proto::SampleMessage& sample) noexcept;
  bool DeriveKeys(const std::uint8_t* own_secret, const std::uint8_t* peer_public, Keys& out) noexcept;
  bool Plausible(const Keys& keys, const proto::SampleMessage& sample, bool newest) const noexcept;
  void Wipe(Keys& keys) noexcept;

  SecureSessionConfig config_;
  proto::SenderRole peer_;
  PreSharedKey psk_;
  Key handshake_key_{};
  SecureRateLimiter datagram_bucket_;
  SecureRateLimiter handshake_bucket_;

  // Handshake in progress: our ephemeral key pair, the hello and welcome bytes (the transcript).
  bool handshaking_ = false;
  Key ephemeral_secret_{};
  Key ephemeral_public_{};
  std::array<std::uint8_t, proto::secure_wire::kKeyExchangeSize> hello_{};
  std::array<std::uint8_t, proto::secure_wire::kKeyExchangeSize> welcome_{};

  Keys current_{};
  Keys pending_{};  ///< Responder: derived at hello, promoted by a valid confirm or first valid frame.
  std::array<std::uint8_t, proto::kMaxFramePlaintextBytes> plaintext_{};
  SecureCounters counters_{};
};

}  // namespace teleop::transport
