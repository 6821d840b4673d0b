#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
#include <thread>

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
//   hello   M→S  e_M, timestamp,           MAC(k_hs, hello[0..48))
//   welcome S→M  e_S,                      MAC(k_hs, hello ‖ welcome[0..40))
//   confirm M→S  session id,               MAC(k_confirm, confirm[0..16))
// k_hs = KDF(PSK, 1, "TLOPhsk1"), k_mix = KDF(PSK, 2, "TLOPhsk1") (the PSK itself is wiped once both are derived);
// secret = BLAKE2b-256(key = k_mix, X25519(e, e') ‖ hello ‖ welcome);
// k_M→S, k_S→M, k_confirm, session id = KDF(secret, 1..4, "TLOPsess"). Frames: ChaCha20-Poly1305 (IETF) with the
// 28-byte clear header as associated data and FrameNonce(sender, sequence) as nonce.
//
// Availability (docs/security.md, "Staying up under attack"): nothing unauthenticated spends a budget the genuine
// peer needs. Authentic frames and handshake messages never take a token; every rejected datagram takes one from
// the rejection bucket (beyond it, it is counted kRateLimited instead of its reason). Only the X25519 of an
// authentic, fresh hello or welcome takes a token from the handshake bucket. A byte-identical copy of the last
// hello answered gets the same welcome again (no X25519, the pending session untouched); an authentic hello whose
// timestamp is not newer than the last answered is refused (kStaleHandshake). The master likewise answers a copy
// of the welcome it accepted with the same confirm until the slave's first frame shows the confirm arrived.
// Keys (derived handshake and mixing keys, ephemeral secret, session keys, decrypted plaintext) live in one
// sodium_malloc block: locked in memory, excluded from core dumps (MADV_DONTDUMP), guard pages around it.

/// Configuration of one end. Set-up values; the constructor checks them (teleop::Error).
struct SecureSessionConfig {
  proto::SenderRole role = proto::SenderRole::kMaster;  ///< The master initiates the handshake.
  int dof = 1;                                          ///< Samples must carry exactly this many DOF.
  /// Plausibility of accepted samples: a peer sample whose velocity, force, or position step since the previous
  /// newest sample (over the sender's clock) exceeds these is rejected (counted `implausible`), like a lost sample.
  double max_speed_m_per_s = 2.0;
  double max_force_N = 100.0;
  double position_slack_m = 1e-3;  ///< Allowed on top of max_speed · Δt (quantization, estimator noise).
  /// Rate limits: a token bucket over rejected datagrams only (an authentic frame never takes a token), and one
  /// over the X25519 step of authentic, fresh hellos and welcomes (~50 µs each). Time is the caller's clock.
  double max_datagrams_per_s = 20000.0;
  double datagram_burst = 512.0;
  double max_handshakes_per_s = 20.0;
  double handshake_burst = 4.0;
  /// X25519 off the caller's thread (UdpLink sets it): a helper thread makes the next ephemeral key pair ahead of
  /// time and computes the Diffie-Hellman and key derivation of an accepted hello or welcome; Receive() only hands
  /// it over (lock-free, one atomic store and a futex wake) and Pump() installs the result and writes the welcome or
  /// confirm. One exchange in flight; a newer authentic hello while it runs is queued (the newest only) and answered
  /// instead once it is done. false: everything inline (tests, fuzzing, benchmarks of the primitives).
  bool offload_key_exchange = false;
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
  std::uint64_t sessions_established = 0;     ///< Handshakes completed (this end switched to a new session).
  std::uint64_t handshakes_started = 0;       ///< Hellos sent (initiator) or answered with X25519 (responder).
  std::uint64_t replies_repeated = 0;         ///< Copies of the last hello (welcome) answered again from the cache.
  std::uint64_t key_exchanges_offloaded = 0;  ///< X25519 steps the helper thread did (offload_key_exchange).
  std::uint64_t key_pairs_inline = 0;  ///< Hellos whose key pair BeginHandshake made itself (X25519 in the caller).
  std::uint64_t sealed = 0;            ///< Frames produced by Seal().
  std::uint64_t seal_refused = 0;      ///< Seal() calls that produced nothing (no session, bad sample).

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

  /// Initiator (master) only: writes a hello with a fresh ephemeral key into `out` (≥ proto::secure_wire::
  /// kHelloSize bytes) and returns its size (0 for a responder or a short buffer). Call again to retry; a running
  /// session keeps working until the new handshake completes (that is also how to re-key). The hello carries
  /// max(timestamp_ns, previous + 1): strictly increasing within this object, and across restarts as long as the
  /// clock passed in does not go back (the one-argument form uses CLOCK_REALTIME, as WireGuard's TAI64N does).
  /// Not for the cycle: it draws randomness and does X25519.
  [[nodiscard]] std::size_t BeginHandshake(std::span<std::uint8_t> out, std::uint64_t timestamp_ns) noexcept;
  [[nodiscard]] std::size_t BeginHandshake(std::span<std::uint8_t> out) noexcept;

  /// Initiator: true when BeginHandshake() would do no X25519 (offload_key_exchange and the helper thread has made
  /// the next key pair), or without offload (where it always computes inline). UdpLink sends a hello only then, so
  /// the cycle never does the exchange; the helper makes a pair in about 0.1 ms after the last one was taken.
  /// Real-time safe: one atomic load.
  bool HelloReady() const noexcept;

  /// offload_key_exchange: installs a key exchange the helper thread finished and writes the message it calls for
  /// (responder: the welcome; initiator: the confirm, switching to the new session) into `reply` (≥ proto::
  /// kMaxSecureMessageSize bytes); returns its size, 0 when nothing is ready. Call once per cycle, before Receive().
  /// Real-time safe: an atomic load, copies, and for the initiator one HMAC. Without offload it returns 0.
  [[nodiscard]] std::size_t Pump(std::span<std::uint8_t> reply) noexcept;

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
  std::uint64_t session_id() const noexcept;
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

  // Secret material, in sodium_malloc'd memory (see above).
  // One key exchange handed to the helper thread (offload_key_exchange). Written by the owner while idle, by the
  // helper while requested; the state's release/acquire orders the hand-over.
  struct Job {
    bool responder = false;
    std::array<std::uint8_t, proto::secure_wire::kHelloSize> hello{};
    std::array<std::uint8_t, proto::secure_wire::kWelcomeSize> welcome{};  ///< Initiator: input; responder: output.
    Key own_secret{};   ///< Initiator: our ephemeral secret (responder: drawn by the helper).
    Key peer_public{};  ///< The peer's ephemeral key.
    Key own_public{};   ///< Responder: output.
    bool ok = false;
    Keys derived{};
  };
  enum JobState : int { kIdle = 0, kRequested = 1, kDone = 2 };

  struct Secrets {
    Key handshake_key{};  ///< k_hs: MACs of hello and welcome.
    Key mix_key{};        ///< k_mix: keys the BLAKE2b that makes the session secret.
    Key ephemeral_secret{};
    Keys current{};
    Keys pending{};  ///< Responder: derived at hello, promoted by a valid confirm or first valid frame.
    std::array<std::uint8_t, proto::kMaxFramePlaintextBytes> plaintext{};
    Job job{};
    Key next_secret{};  ///< Initiator, offload: the next ephemeral key pair, made ahead by the helper.
    Key next_public{};
  };

  SecureReceiveResult Count(SecureReceiveResult result, std::uint64_t now_ns) noexcept;
  SecureReceiveResult OnHello(std::span<const std::uint8_t> datagram, std::uint64_t now_ns,
                              std::span<std::uint8_t> reply) noexcept;
  SecureReceiveResult OnWelcome(std::span<const std::uint8_t> datagram, std::uint64_t now_ns,
                                std::span<std::uint8_t> reply) noexcept;
  SecureReceiveResult OnConfirm(std::span<const std::uint8_t> datagram) noexcept;
  SecureReceiveResult OnFrame(std::span<const std::uint8_t> datagram, proto::SampleMessage& sample) noexcept;
  bool DeriveKeys(const std::uint8_t* own_secret, const std::uint8_t* peer_public, Keys& out) noexcept;
  bool DeriveKeys(const std::uint8_t* own_secret, const std::uint8_t* peer_public, std::span<const std::uint8_t> hello,
                  std::span<const std::uint8_t> welcome, Keys& out) const noexcept;
  void RunHelper() noexcept;
  void RunJob(Job& job) noexcept;
  void Kick() noexcept;
  std::size_t FinishConfirm(Keys& derived, std::span<std::uint8_t> reply) noexcept;
  bool Plausible(const Keys& keys, const proto::SampleMessage& sample, bool newest) const noexcept;
  static void Wipe(Keys& keys) noexcept;

  SecureSessionConfig config_;
  proto::SenderRole peer_;
  Secrets* secrets_ = nullptr;  ///< Owned; sodium_malloc / sodium_free.
  SecureRateLimiter datagram_bucket_;
  SecureRateLimiter handshake_bucket_;

  // Handshake in progress: our ephemeral public key, the hello and welcome bytes (the transcript).
  bool handshaking_ = false;
  Key ephemeral_public_{};
  std::array<std::uint8_t, proto::secure_wire::kHelloSize> hello_{};
  std::array<std::uint8_t, proto::secure_wire::kWelcomeSize> welcome_{};
  // Responder: hello_ and welcome_ are the last hello answered and its welcome (answered_), its timestamp the newest.
  bool answered_ = false;
  std::uint64_t newest_hello_timestamp_ = 0;
  // Initiator: the last timestamp sent; the confirm of the current session, re-sent for a copy of its welcome
  // until the responder's first authentic frame.
  std::uint64_t last_sent_timestamp_ = 0;
  bool confirm_cached_ = false;
  std::array<std::uint8_t, proto::secure_wire::kConfirmSize> confirm_{};

  SecureCounters counters_{};

  // offload_key_exchange: the helper thread and its two hand-over slots (JobState), woken through kick_.
  std::atomic<int> job_state_{kIdle};
  std::atomic<int> pair_state_{kIdle};  ///< kDone: next_secret/next_public ready for BeginHandshake.
  std::atomic<std::uint32_t> kick_{0};
  std::atomic<bool> stop_{false};
  // Responder, offload: a newer authentic hello that arrived while an exchange ran (the newest only); started when
  // that one finishes, whose result it supersedes (a master retrying after a stall waits for its newest hello).
  bool hello_queued_ = false;
  std::array<std::uint8_t, proto::secure_wire::kHelloSize> queued_hello_{};
  Key queued_public_{};
  std::atomic<std::uint64_t> counters_offloaded_{0};  ///< Written by the helper; Pump() copies it into counters_.
  std::thread helper_;
};

}  // namespace teleop::transport
