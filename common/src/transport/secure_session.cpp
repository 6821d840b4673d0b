#include "teleop/transport/secure_session.hpp"

#include <sodium.h>

#include <cmath>
#include <ctime>
#include <new>
#include <string>
#include <system_error>

#include "teleop/error.hpp"
#include "teleop/proto/codec.hpp"
#include "teleop/runtime/background_thread.hpp"

namespace teleop::transport {
namespace {

namespace sw = proto::secure_wire;

static_assert(proto::kEphemeralKeyBytes == crypto_scalarmult_BYTES);
static_assert(proto::kEphemeralKeyBytes == crypto_scalarmult_SCALARBYTES);
static_assert(proto::kHandshakeTagBytes == crypto_auth_hmacsha512256_BYTES);
static_assert(crypto_auth_hmacsha512256_KEYBYTES == 32);
static_assert(proto::kFrameTagBytes == crypto_aead_chacha20poly1305_ietf_ABYTES);
static_assert(crypto_aead_chacha20poly1305_ietf_KEYBYTES == 32);
static_assert(crypto_aead_chacha20poly1305_ietf_NPUBBYTES == 12);
static_assert(crypto_kdf_KEYBYTES == 32);

// KDF contexts (exactly crypto_kdf_CONTEXTBYTES = 8 characters) and subkey ids (docs/protocol.md).
constexpr char kHandshakeContext[] = "TLOPhsk1";
constexpr char kSessionContext[] = "TLOPsess";
static_assert(sizeof kHandshakeContext - 1 == crypto_kdf_CONTEXTBYTES);
static_assert(sizeof kSessionContext - 1 == crypto_kdf_CONTEXTBYTES);
constexpr std::uint64_t kSubkeyHandshake = 1;
constexpr std::uint64_t kSubkeyMix = 2;
constexpr std::uint64_t kSubkeyMasterToSlave = 1;
constexpr std::uint64_t kSubkeySlaveToMaster = 2;
constexpr std::uint64_t kSubkeyConfirm = 3;
constexpr std::uint64_t kSubkeySessionId = 4;

void Mac(const std::uint8_t* key, std::span<const std::uint8_t> a, std::span<const std::uint8_t> b,
         std::uint8_t* tag) noexcept {
  crypto_auth_hmacsha512256_state state;
  crypto_auth_hmacsha512256_init(&state, key, crypto_auth_hmacsha512256_KEYBYTES);
  crypto_auth_hmacsha512256_update(&state, a.data(), a.size());
  if (!b.empty()) crypto_auth_hmacsha512256_update(&state, b.data(), b.size());
  crypto_auth_hmacsha512256_final(&state, tag);
  sodium_memzero(&state, sizeof state);
}

bool MacMatches(const std::uint8_t* key, std::span<const std::uint8_t> a, std::span<const std::uint8_t> b,
                const std::uint8_t* tag) noexcept {
  std::array<std::uint8_t, proto::kHandshakeTagBytes> expected{};
  Mac(key, a, b, expected.data());
  return crypto_verify_32(expected.data(), tag) == 0;  // constant time
}

std::uint64_t LoadU64(const std::uint8_t* p) noexcept {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

const char* ToString(SecureReceiveStatus status) noexcept {
  switch (status) {
    case SecureReceiveStatus::kSample:
      return "sample";
    case SecureReceiveStatus::kHandshake:
      return "handshake";
    case SecureReceiveStatus::kRateLimited:
      return "rate_limited";
    case SecureReceiveStatus::kHandshakeRateLimited:
      return "handshake_rate_limited";
    case SecureReceiveStatus::kInsecure:
      return "insecure";
    case SecureReceiveStatus::kMalformed:
      return "malformed";
    case SecureReceiveStatus::kWrongSender:
      return "wrong_sender";
    case SecureReceiveStatus::kUnexpectedHandshake:
      return "unexpected_handshake";
    case SecureReceiveStatus::kBadHandshakeTag:
      return "bad_handshake_tag";
    case SecureReceiveStatus::kNoSession:
      return "no_session";
    case SecureReceiveStatus::kWrongSession:
      return "wrong_session";
    case SecureReceiveStatus::kReplayed:
      return "replayed";
    case SecureReceiveStatus::kTooOld:
      return "too_old";
    case SecureReceiveStatus::kBadTag:
      return "bad_tag";
    case SecureReceiveStatus::kBadPlaintext:
      return "bad_plaintext";
    case SecureReceiveStatus::kImplausible:
      return "implausible";
    case SecureReceiveStatus::kStaleHandshake:
      return "stale_handshake";
    case SecureReceiveStatus::kCount:
      break;
  }
  return "invalid";
}

std::uint64_t SecureCounters::rejected() const noexcept {
  std::uint64_t sum = 0;
  for (std::size_t i = 0; i < by_status.size(); ++i) {
    const auto s = static_cast<SecureReceiveStatus>(i);
    if (s != SecureReceiveStatus::kSample && s != SecureReceiveStatus::kHandshake) sum += by_status[i];
  }
  return sum;
}

SecureSession::SecureSession(const SecureSessionConfig& config, const PreSharedKey& key)
    : config_(config),
      peer_(proto::PeerOf(config.role)),
      datagram_bucket_(config.max_datagrams_per_s, config.datagram_burst),
      handshake_bucket_(config.max_handshakes_per_s, config.handshake_burst) {
  if (sodium_init() < 0) throw Error("secure session: libsodium failed to initialise");
  if (config.role != proto::SenderRole::kMaster && config.role != proto::SenderRole::kSlave) {
    throw Error("secure session: role must be master or slave");
  }
  if (config.dof < 1 || config.dof > proto::kMaxWireDof) {
    throw Error("secure session: dof " + std::to_string(config.dof) + " outside 1.." +
                std::to_string(proto::kMaxWireDof));
  }
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(config.max_speed_m_per_s) || !positive(config.max_force_N) || !std::isfinite(config.position_slack_m) ||
      config.position_slack_m < 0.0) {
    throw Error(
        "secure session: plausibility bounds must be finite and positive (max_speed_m_per_s, max_force_N; "
        "position_slack_m >= 0)");
  }
  if (!positive(config.max_datagrams_per_s) || !positive(config.max_handshakes_per_s) ||
      !(config.datagram_burst >= 1.0) || !(config.handshake_burst >= 1.0)) {
    throw Error("secure session: rate limits must be positive, bursts at least 1");
  }
  if (sodium_is_zero(key.bytes().data(), key.bytes().size()) == 1) {
    throw Error("secure session: the pre-shared key is all zero");
  }
  // Locked, not dumped, guarded (sodium_malloc); the PSK is used here once and not kept.
  void* block = sodium_malloc(sizeof(Secrets));
  if (block == nullptr) throw Error("secure session: cannot allocate locked memory for the keys");
  secrets_ = new (block) Secrets{};
  crypto_kdf_derive_from_key(secrets_->handshake_key.data(), kKeyBytes, kSubkeyHandshake, kHandshakeContext,
                             key.bytes().data());
  crypto_kdf_derive_from_key(secrets_->mix_key.data(), kKeyBytes, kSubkeyMix, kHandshakeContext, key.bytes().data());
  if (config_.offload_key_exchange) {
    try {
      helper_ = std::thread([this] {
        runtime::BecomeBackgroundThread("teleop-kex");
        RunHelper();
      });
    } catch (const std::system_error& e) {
      secrets_->~Secrets();
      sodium_free(secrets_);
      throw Error(std::string("secure session: cannot start the key-exchange thread: ") + e.what());
    }
    Kick();  // the initiator's first key pair, ahead of the first hello
  }
}

void SecureSession::Kick() noexcept {
  kick_.fetch_add(1, std::memory_order_release);
  kick_.notify_one();
}

// The helper thread: sleeps on kick_, runs a requested key exchange, and keeps one ephemeral key pair ready for the
// initiator's next hello. Only it writes a requested job or an empty pair slot; only the owner the others.
void SecureSession::RunHelper() noexcept {
  std::uint32_t seen = 0;
  while (!stop_.load(std::memory_order_acquire)) {
    if (job_state_.load(std::memory_order_acquire) == kRequested) {
      RunJob(secrets_->job);
      ++counters_offloaded_;
      job_state_.store(kDone, std::memory_order_release);
    }
    if (config_.role == proto::SenderRole::kMaster && pair_state_.load(std::memory_order_acquire) == kIdle) {
      randombytes_buf(secrets_->next_secret.data(), kKeyBytes);
      if (crypto_scalarmult_base(secrets_->next_public.data(), secrets_->next_secret.data()) == 0) {
        pair_state_.store(kDone, std::memory_order_release);
      }
    }
    const std::uint32_t now = kick_.load(std::memory_order_acquire);
    if (now == seen) {
      kick_.wait(seen, std::memory_order_acquire);
    }
    seen = kick_.load(std::memory_order_acquire);
  }
}

void SecureSession::RunJob(Job& job) noexcept {
  job.ok = false;
  if (job.responder) {
    // The welcome: a fresh key pair, its MAC over hello ‖ welcome, then the keys from that transcript.
    randombytes_buf(job.own_secret.data(), kKeyBytes);
    if (crypto_scalarmult_base(job.own_public.data(), job.own_secret.data()) != 0) return;
    proto::KeyExchangeMessage welcome{};
    welcome.type = proto::SecureMessageType::kWelcome;
    welcome.sender = config_.role;
    welcome.ephemeral_key = job.own_public;
    if (proto::EncodeKeyExchange(welcome, job.welcome) != sw::kWelcomeSize) return;
    Mac(secrets_->handshake_key.data(), job.hello, std::span(job.welcome).first(sw::kKeyExchangeTagOffset),
        job.welcome.data() + sw::kKeyExchangeTagOffset);
  }
  job.ok = DeriveKeys(job.own_secret.data(), job.peer_public.data(), job.hello, job.welcome, job.derived);
  sodium_memzero(job.own_secret.data(), kKeyBytes);
}

SecureSession::~SecureSession() {
  if (helper_.joinable()) {
    stop_.store(true, std::memory_order_release);
    Kick();
    helper_.join();
  }
  Wipe(secrets_->current);
  Wipe(secrets_->pending);
  secrets_->~Secrets();
  sodium_free(secrets_);  // zeroes the block before releasing it
}

void SecureSession::Wipe(Keys& keys) noexcept {
  sodium_memzero(keys.tx.data(), keys.tx.size());
  sodium_memzero(keys.rx.data(), keys.rx.size());
  sodium_memzero(keys.confirm.data(), keys.confirm.size());
  keys = Keys{};
}

std::uint64_t SecureSession::session_id() const noexcept { return secrets_->current.active ? secrets_->current.id : 0; }

SecureSessionState SecureSession::state() const noexcept {
  if (secrets_->current.active) return SecureSessionState::kEstablished;
  if (handshaking_ || secrets_->pending.active) return SecureSessionState::kHandshaking;
  return SecureSessionState::kNoSession;
}

SecureReceiveResult SecureSession::Count(SecureReceiveResult result, std::uint64_t now_ns) noexcept {
  // Only rejections take a token (never an authentic frame or handshake message): beyond the bucket they are
  // counted as a flood instead of by reason.
  const bool accepted =
      result.status == SecureReceiveStatus::kSample || result.status == SecureReceiveStatus::kHandshake;
  if (!accepted && !datagram_bucket_.TryTake(now_ns)) result = {SecureReceiveStatus::kRateLimited};
  ++counters_.by_status[static_cast<std::size_t>(result.status)];
  return result;
}

std::size_t SecureSession::BeginHandshake(std::span<std::uint8_t> out) noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  const auto now = static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(ts.tv_nsec);
  return BeginHandshake(out, now);
}

bool SecureSession::HelloReady() const noexcept {
  return !config_.offload_key_exchange || pair_state_.load(std::memory_order_acquire) == kDone;
}

std::size_t SecureSession::BeginHandshake(std::span<std::uint8_t> out, std::uint64_t timestamp_ns) noexcept {
  if (config_.role != proto::SenderRole::kMaster || out.size() < sw::kHelloSize) return 0;
  if (pair_state_.load(std::memory_order_acquire) == kDone) {
    // Made ahead by the helper thread: no X25519 here. It makes the next one now.
    secrets_->ephemeral_secret = secrets_->next_secret;
    ephemeral_public_ = secrets_->next_public;
    sodium_memzero(secrets_->next_secret.data(), kKeyBytes);
    pair_state_.store(kIdle, std::memory_order_release);
    Kick();
  } else {
    ++counters_.key_pairs_inline;
    randombytes_buf(secrets_->ephemeral_secret.data(), kKeyBytes);
    if (crypto_scalarmult_base(ephemeral_public_.data(), secrets_->ephemeral_secret.data()) != 0) return 0;
  }
  proto::KeyExchangeMessage hello{};
  hello.type = proto::SecureMessageType::kHello;
  hello.sender = config_.role;
  hello.ephemeral_key = ephemeral_public_;
  hello.timestamp = std::max(timestamp_ns, last_sent_timestamp_ + 1);
  if (proto::EncodeKeyExchange(hello, hello_) != sw::kHelloSize) return 0;
  Mac(secrets_->handshake_key.data(), std::span(hello_).first(sw::kHelloTagOffset), {},
      hello_.data() + sw::kHelloTagOffset);
  last_sent_timestamp_ = hello.timestamp;
  std::copy(hello_.begin(), hello_.end(), out.begin());
  handshaking_ = true;
  ++counters_.handshakes_started;
  return sw::kHelloSize;
}

// secret = BLAKE2b-256(key = k_mix, X25519(own, peer) ‖ hello ‖ welcome); the session keys and id are KDF subkeys of
// it. Mixing the PSK in (through k_mix, derived from it once; as Noise's psk modes and WireGuard do) means even a
// broken MAC check could not let a party without the PSK derive the keys; the transcript binds the keys to this
// exchange.
bool SecureSession::DeriveKeys(const std::uint8_t* own_secret, const std::uint8_t* peer_public, Keys& out) noexcept {
  return DeriveKeys(own_secret, peer_public, hello_, welcome_, out);
}

bool SecureSession::DeriveKeys(const std::uint8_t* own_secret, const std::uint8_t* peer_public,
                               std::span<const std::uint8_t> hello, std::span<const std::uint8_t> welcome,
                               Keys& out) const noexcept {
  std::array<std::uint8_t, crypto_scalarmult_BYTES> shared{};
  if (crypto_scalarmult(shared.data(), own_secret, peer_public) != 0) return false;  // low-order point
  std::array<std::uint8_t, crypto_kdf_KEYBYTES> secret{};
  crypto_generichash_state state;
  crypto_generichash_init(&state, secrets_->mix_key.data(), kKeyBytes, secret.size());
  crypto_generichash_update(&state, shared.data(), shared.size());
  crypto_generichash_update(&state, hello.data(), hello.size());
  crypto_generichash_update(&state, welcome.data(), welcome.size());
  crypto_generichash_final(&state, secret.data(), secret.size());
  sodium_memzero(&state, sizeof state);
  sodium_memzero(shared.data(), shared.size());

  Key master_to_slave{};
  Key slave_to_master{};
  std::array<std::uint8_t, 16> id{};
  crypto_kdf_derive_from_key(master_to_slave.data(), kKeyBytes, kSubkeyMasterToSlave, kSessionContext, secret.data());
  crypto_kdf_derive_from_key(slave_to_master.data(), kKeyBytes, kSubkeySlaveToMaster, kSessionContext, secret.data());
  crypto_kdf_derive_from_key(out.confirm.data(), kKeyBytes, kSubkeyConfirm, kSessionContext, secret.data());
  crypto_kdf_derive_from_key(id.data(), id.size(), kSubkeySessionId, kSessionContext, secret.data());
  sodium_memzero(secret.data(), secret.size());
  const bool master = config_.role == proto::SenderRole::kMaster;
  out.tx = master ? master_to_slave : slave_to_master;
  out.rx = master ? slave_to_master : master_to_slave;
  sodium_memzero(master_to_slave.data(), kKeyBytes);
  sodium_memzero(slave_to_master.data(), kKeyBytes);
  out.id = LoadU64(id.data());
  out.active = true;
  out.next_tx_sequence = 0;
  out.window = SecureReplayWindow{};
  out.have_newest = false;
  return true;
}

SecureReceiveResult SecureSession::Receive(std::span<const std::uint8_t> datagram, std::uint64_t now_ns,
                                           std::span<std::uint8_t> reply, proto::SampleMessage& sample) noexcept {
  ++counters_.received;
  const proto::DatagramKind kind = proto::ClassifyDatagram(datagram);
  if (kind.status != proto::DecodeStatus::kOk) return Count({SecureReceiveStatus::kMalformed}, now_ns);
  if (kind.version == proto::kProtocolVersion) return Count({SecureReceiveStatus::kInsecure}, now_ns);
  if (kind.version != proto::kSecureProtocolVersion) return Count({SecureReceiveStatus::kMalformed}, now_ns);
  switch (static_cast<proto::SecureMessageType>(kind.type)) {
    case proto::SecureMessageType::kFrame:
      return Count(OnFrame(datagram, sample), now_ns);
    case proto::SecureMessageType::kHello:
      return Count(OnHello(datagram, now_ns, reply), now_ns);
    case proto::SecureMessageType::kWelcome:
      return Count(OnWelcome(datagram, now_ns, reply), now_ns);
    case proto::SecureMessageType::kConfirm:
      return Count(OnConfirm(datagram), now_ns);
  }
  return Count({SecureReceiveStatus::kMalformed}, now_ns);
}

SecureReceiveResult SecureSession::OnHello(std::span<const std::uint8_t> datagram, std::uint64_t now_ns,
                                           std::span<std::uint8_t> reply) noexcept {
  proto::KeyExchangeMessage hello{};
  if (proto::DecodeKeyExchange(datagram, hello) != proto::DecodeStatus::kOk) return {SecureReceiveStatus::kMalformed};
  if (hello.sender != peer_) return {SecureReceiveStatus::kWrongSender};
  if (config_.role != proto::SenderRole::kSlave) return {SecureReceiveStatus::kUnexpectedHandshake};
  if (reply.size() < sw::kWelcomeSize) return {SecureReceiveStatus::kUnexpectedHandshake};
  // A copy of the last hello answered (a duplicating network, a retransmission, a replay): the same welcome again,
  // nothing else changes. Its MAC was checked when it was first answered.
  if (answered_ && sodium_memcmp(datagram.data(), hello_.data(), sw::kHelloSize) == 0) {
    std::copy(welcome_.begin(), welcome_.end(), reply.begin());
    ++counters_.replies_repeated;
    return {SecureReceiveStatus::kHandshake, sw::kWelcomeSize};
  }
  if (!MacMatches(secrets_->handshake_key.data(), datagram.first(sw::kHelloTagOffset), {}, hello.tag.data())) {
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  if (config_.offload_key_exchange) {
    // A copy of the hello in flight: its welcome comes from Pump().
    const int state = job_state_.load(std::memory_order_acquire);
    if (state != kIdle && secrets_->job.responder &&
        sodium_memcmp(datagram.data(), secrets_->job.hello.data(), sw::kHelloSize) == 0) {
      return {SecureReceiveStatus::kHandshake};
    }
    if (hello_queued_ && sodium_memcmp(datagram.data(), queued_hello_.data(), sw::kHelloSize) == 0) {
      return {SecureReceiveStatus::kHandshake};
    }
  }
  // Authentic, but not newer than the last answered: a replay of an older hello (WireGuard's TAI64N rule).
  // (Every hello carries a timestamp ≥ 1, so the initial 0 refuses nothing.)
  if (hello.timestamp <= newest_hello_timestamp_) return {SecureReceiveStatus::kStaleHandshake};
  // Only now, for an authentic and fresh hello, the expensive step is rate-limited.
  if (!handshake_bucket_.TryTake(now_ns)) return {SecureReceiveStatus::kHandshakeRateLimited};
  if (config_.offload_key_exchange) {
    newest_hello_timestamp_ = hello.timestamp;  // older ones are refused from now on
    if (job_state_.load(std::memory_order_acquire) != kIdle) {
      // One exchange at a time: this newer hello is answered when the running one is done (which it supersedes).
      std::copy(datagram.begin(), datagram.end(), queued_hello_.begin());
      queued_public_ = hello.ephemeral_key;
      hello_queued_ = true;
      return {SecureReceiveStatus::kHandshake};
    }
    Job& job = secrets_->job;
    job.responder = true;
    std::copy(datagram.begin(), datagram.end(), job.hello.begin());
    job.peer_public = hello.ephemeral_key;
    job_state_.store(kRequested, std::memory_order_release);
    Kick();
    return {SecureReceiveStatus::kHandshake};
  }
  // A valid hello starts a new pending session; the established one (if any) keeps working until the initiator
  // proves it holds the new keys (confirm or first frame).
  std::array<std::uint8_t, sw::kHelloSize> hello_bytes{};
  std::copy(datagram.begin(), datagram.end(), hello_bytes.begin());
  randombytes_buf(secrets_->ephemeral_secret.data(), kKeyBytes);
  Key own_public{};
  if (crypto_scalarmult_base(own_public.data(), secrets_->ephemeral_secret.data()) != 0) {
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  proto::KeyExchangeMessage welcome{};
  welcome.type = proto::SecureMessageType::kWelcome;
  welcome.sender = config_.role;
  welcome.ephemeral_key = own_public;
  std::array<std::uint8_t, sw::kWelcomeSize> welcome_bytes{};
  if (proto::EncodeKeyExchange(welcome, welcome_bytes) != sw::kWelcomeSize) return {SecureReceiveStatus::kMalformed};
  Mac(secrets_->handshake_key.data(), hello_bytes, std::span(welcome_bytes).first(sw::kKeyExchangeTagOffset),
      welcome_bytes.data() + sw::kKeyExchangeTagOffset);
  // The transcript DeriveKeys hashes is hello_ ‖ welcome_.
  const auto old_hello = hello_;
  const auto old_welcome = welcome_;
  hello_ = hello_bytes;
  welcome_ = welcome_bytes;
  Keys derived{};
  if (!DeriveKeys(secrets_->ephemeral_secret.data(), hello.ephemeral_key.data(), derived)) {
    Wipe(derived);
    sodium_memzero(secrets_->ephemeral_secret.data(), kKeyBytes);
    hello_ = old_hello;  // a low-order key: the cache keeps the last hello that was answered
    welcome_ = old_welcome;
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  sodium_memzero(secrets_->ephemeral_secret.data(), kKeyBytes);
  ephemeral_public_ = own_public;
  Wipe(secrets_->pending);
  secrets_->pending = derived;
  Wipe(derived);
  answered_ = true;
  newest_hello_timestamp_ = hello.timestamp;
  std::copy(welcome_.begin(), welcome_.end(), reply.begin());
  ++counters_.handshakes_started;
  return {SecureReceiveStatus::kHandshake, sw::kWelcomeSize};
}

SecureReceiveResult SecureSession::OnWelcome(std::span<const std::uint8_t> datagram, std::uint64_t now_ns,
                                             std::span<std::uint8_t> reply) noexcept {
  proto::KeyExchangeMessage welcome{};
  if (proto::DecodeKeyExchange(datagram, welcome) != proto::DecodeStatus::kOk) {
    return {SecureReceiveStatus::kMalformed};
  }
  if (welcome.sender != peer_) return {SecureReceiveStatus::kWrongSender};
  if (config_.role != proto::SenderRole::kMaster) return {SecureReceiveStatus::kUnexpectedHandshake};
  if (reply.size() < sw::kConfirmSize) return {SecureReceiveStatus::kUnexpectedHandshake};
  if (!handshaking_) {
    // A copy of the welcome that established the current session, before the slave's first frame: its confirm
    // may have been lost, so the same confirm again. Anything else is not awaited.
    if (confirm_cached_ && sodium_memcmp(datagram.data(), welcome_.data(), sw::kWelcomeSize) == 0) {
      std::copy(confirm_.begin(), confirm_.end(), reply.begin());
      ++counters_.replies_repeated;
      return {SecureReceiveStatus::kHandshake, sw::kConfirmSize};
    }
    return {SecureReceiveStatus::kUnexpectedHandshake};
  }
  if (!MacMatches(secrets_->handshake_key.data(), hello_, datagram.first(sw::kKeyExchangeTagOffset),
                  welcome.tag.data())) {
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  if (config_.offload_key_exchange) {
    const int state = job_state_.load(std::memory_order_acquire);
    if (state != kIdle && !secrets_->job.responder &&
        sodium_memcmp(datagram.data(), secrets_->job.welcome.data(), sw::kWelcomeSize) == 0) {
      return {SecureReceiveStatus::kHandshake};  // a copy of the welcome in flight: the confirm comes from Pump()
    }
    if (state != kIdle) return {SecureReceiveStatus::kHandshakeRateLimited};
  }
  if (!handshake_bucket_.TryTake(now_ns)) return {SecureReceiveStatus::kHandshakeRateLimited};
  std::copy(datagram.begin(), datagram.end(), welcome_.begin());
  if (config_.offload_key_exchange) {
    Job& job = secrets_->job;
    job.responder = false;
    job.hello = hello_;
    job.welcome = welcome_;
    job.own_secret = secrets_->ephemeral_secret;
    job.peer_public = welcome.ephemeral_key;
    job_state_.store(kRequested, std::memory_order_release);
    Kick();
    return {SecureReceiveStatus::kHandshake};
  }
  Keys derived{};
  if (!DeriveKeys(secrets_->ephemeral_secret.data(), welcome.ephemeral_key.data(), derived)) {
    Wipe(derived);
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  const std::size_t size = FinishConfirm(derived, reply);
  if (size == 0) return {SecureReceiveStatus::kMalformed};
  return {SecureReceiveStatus::kHandshake, size};
}

// Initiator: the confirm for freshly derived keys, and the switch to them.
std::size_t SecureSession::FinishConfirm(Keys& derived, std::span<std::uint8_t> reply) noexcept {
  proto::ConfirmMessage confirm{};
  confirm.sender = config_.role;
  confirm.session_id = derived.id;
  if (proto::EncodeConfirm(confirm, confirm_) != sw::kConfirmSize || reply.size() < sw::kConfirmSize) {
    Wipe(derived);
    return 0;
  }
  Mac(derived.confirm.data(), std::span(confirm_).first(sw::kConfirmTagOffset), {},
      confirm_.data() + sw::kConfirmTagOffset);
  std::copy(confirm_.begin(), confirm_.end(), reply.begin());
  confirm_cached_ = true;
  // The initiator switches now: the welcome proved the responder holds the PSK and answered this very hello.
  sodium_memzero(secrets_->ephemeral_secret.data(), kKeyBytes);
  handshaking_ = false;
  Wipe(secrets_->current);
  secrets_->current = derived;
  Wipe(derived);
  ++counters_.sessions_established;
  return sw::kConfirmSize;
}

std::size_t SecureSession::Pump(std::span<std::uint8_t> reply) noexcept {
  counters_.key_exchanges_offloaded = counters_offloaded_.load(std::memory_order_relaxed);
  if (!config_.offload_key_exchange || job_state_.load(std::memory_order_acquire) != kDone) return 0;
  Job& job = secrets_->job;
  std::size_t size = 0;
  if (job.responder && hello_queued_) {
    // Superseded by a newer hello: no welcome for this one; start the newer.
    Wipe(job.derived);
    job.hello = queued_hello_;
    job.peer_public = queued_public_;
    hello_queued_ = false;
    job_state_.store(kRequested, std::memory_order_release);
    Kick();
    return 0;
  }
  if (job.responder) {
    if (job.ok && reply.size() >= sw::kWelcomeSize) {
      hello_ = job.hello;
      welcome_ = job.welcome;
      ephemeral_public_ = job.own_public;
      Wipe(secrets_->pending);
      secrets_->pending = job.derived;
      answered_ = true;
      ++counters_.handshakes_started;
      std::copy(welcome_.begin(), welcome_.end(), reply.begin());
      size = sw::kWelcomeSize;
    }
  } else if (job.ok && handshaking_ && sodium_memcmp(job.hello.data(), hello_.data(), sw::kHelloSize) == 0) {
    // Still the hello we are waiting on (a retry since would have a new transcript: then the result is stale).
    sodium_memzero(secrets_->ephemeral_secret.data(), kKeyBytes);
    size = FinishConfirm(job.derived, reply);
  }
  Wipe(job.derived);
  job_state_.store(kIdle, std::memory_order_release);
  return size;
}

SecureReceiveResult SecureSession::OnConfirm(std::span<const std::uint8_t> datagram) noexcept {
  proto::ConfirmMessage confirm{};
  if (proto::DecodeConfirm(datagram, confirm) != proto::DecodeStatus::kOk) return {SecureReceiveStatus::kMalformed};
  if (confirm.sender != peer_) return {SecureReceiveStatus::kWrongSender};
  if (config_.role != proto::SenderRole::kSlave) return {SecureReceiveStatus::kUnexpectedHandshake};
  Keys& pending = secrets_->pending;
  if (!pending.active || confirm.session_id != pending.id) {
    // A byte-identical copy of the confirm that established the current session (the master answers a copy of its
    // welcome with the same confirm): taken, changes nothing. (The responder keeps it in confirm_.) Anything else
    // is not awaited.
    if (confirm_cached_ && secrets_->current.active && confirm.session_id == secrets_->current.id &&
        sodium_memcmp(datagram.data(), confirm_.data(), sw::kConfirmSize) == 0) {
      return {SecureReceiveStatus::kHandshake};
    }
    return {SecureReceiveStatus::kUnexpectedHandshake};
  }
  if (!MacMatches(pending.confirm.data(), datagram.first(sw::kConfirmTagOffset), {}, confirm.tag.data())) {
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  std::copy(datagram.begin(), datagram.end(), confirm_.begin());
  confirm_cached_ = true;
  Wipe(secrets_->current);
  secrets_->current = pending;
  Wipe(pending);
  ++counters_.sessions_established;
  return {SecureReceiveStatus::kHandshake};
}

SecureReceiveResult SecureSession::OnFrame(std::span<const std::uint8_t> datagram,
                                           proto::SampleMessage& sample) noexcept {
  proto::SecureFrameView frame{};
  if (proto::DecodeSecureFrame(datagram, frame) != proto::DecodeStatus::kOk) return {SecureReceiveStatus::kMalformed};
  if (frame.header.sender != peer_) return {SecureReceiveStatus::kWrongSender};
  Keys& current = secrets_->current;
  Keys& pending = secrets_->pending;
  Keys* keys = nullptr;
  if (current.active && frame.header.session_id == current.id) {
    keys = &current;
  } else if (pending.active && frame.header.session_id == pending.id) {
    keys = &pending;
  } else {
    return {current.active || pending.active ? SecureReceiveStatus::kWrongSession : SecureReceiveStatus::kNoSession};
  }
  // Cheap checks before the AEAD; the window is only marked after it (a forged sequence never moves it).
  switch (keys->window.Classify(frame.header.sequence)) {
    case SecureReplayWindow::Check::kReplayed:
      return {SecureReceiveStatus::kReplayed};
    case SecureReplayWindow::Check::kTooOld:
      return {SecureReceiveStatus::kTooOld};
    case SecureReplayWindow::Check::kFresh:
      break;
  }
  const auto nonce = proto::FrameNonce(frame.header.sender, frame.header.sequence);
  if (crypto_aead_chacha20poly1305_ietf_decrypt_detached(
          secrets_->plaintext.data(), nullptr, frame.ciphertext.data(), frame.ciphertext.size(), frame.tag.data(),
          frame.associated_data.data(), frame.associated_data.size(), nonce.data(), keys->rx.data()) != 0) {
    return {SecureReceiveStatus::kBadTag};
  }
  if (keys == &pending) {
    // First authentic frame of the pending session: the initiator holds its keys (its confirm was lost or is late).
    confirm_cached_ = false;  // the responder has no copy of that confirm to compare a late one with
    Wipe(current);
    current = pending;
    Wipe(pending);
    keys = &current;
    ++counters_.sessions_established;
  }
  // Initiator: the responder sends only once it has the confirm, so no copy of its welcome needs answering now.
  if (config_.role == proto::SenderRole::kMaster) confirm_cached_ = false;
  const bool newest = keys->window.Mark(frame.header.sequence);
  proto::SampleMessage decoded{};
  const auto plain = std::span<const std::uint8_t>(secrets_->plaintext).first(frame.ciphertext.size());
  if (proto::DecodeSample(plain, decoded) != proto::DecodeStatus::kOk || decoded.sender != frame.header.sender ||
      decoded.dof != config_.dof || decoded.sequence != static_cast<std::uint32_t>(frame.header.sequence)) {
    return {SecureReceiveStatus::kBadPlaintext};
  }
  if (!Plausible(*keys, decoded, newest)) return {SecureReceiveStatus::kImplausible};
  if (newest) {
    keys->newest = decoded;
    keys->have_newest = true;
  }
  sample = decoded;
  return {SecureReceiveStatus::kSample, 0, newest};
}

bool SecureSession::Plausible(const Keys& keys, const proto::SampleMessage& sample, bool newest) const noexcept {
  const bool check_step = newest && keys.have_newest && sample.sender_time_ns > keys.newest.sender_time_ns;
  const double dt_s = check_step ? static_cast<double>(sample.sender_time_ns - keys.newest.sender_time_ns) * 1e-9 : 0.0;
  for (std::size_t i = 0; i < sample.dof; ++i) {
    if (std::fabs(sample.velocity_m_per_s[i]) > config_.max_speed_m_per_s) return false;
    if (std::fabs(sample.force_N[i]) > config_.max_force_N) return false;
    if (check_step && std::fabs(sample.position_m[i] - keys.newest.position_m[i]) >
                          config_.max_speed_m_per_s * dt_s + config_.position_slack_m) {
      return false;
    }
  }
  return true;
}

std::size_t SecureSession::Seal(const proto::SampleMessage& sample, std::span<std::uint8_t> out) noexcept {
  Keys& current = secrets_->current;
  if (!current.active || sample.sender != config_.role || sample.dof != config_.dof) {
    ++counters_.seal_refused;
    return 0;
  }
  const std::size_t plain_size = proto::EncodedSampleSize(sample.dof, sample.has_energy);
  const std::size_t total = sw::kFrameHeaderSize + plain_size + proto::kFrameTagBytes;
  if (out.size() < total) {
    ++counters_.seal_refused;
    return 0;
  }
  const std::uint64_t sequence = current.next_tx_sequence;
  proto::SampleMessage inner = sample;
  inner.sequence = static_cast<std::uint32_t>(sequence);
  if (proto::EncodeSample(inner, secrets_->plaintext) != plain_size) {
    ++counters_.seal_refused;
    return 0;
  }
  proto::SecureFrameHeader header{};
  header.sender = config_.role;
  header.session_id = current.id;
  header.sequence = sequence;
  header.sealed_length = static_cast<std::uint16_t>(plain_size);
  if (proto::EncodeSecureFrameHeader(header, out) != sw::kFrameHeaderSize) {
    ++counters_.seal_refused;
    return 0;
  }
  const auto nonce = proto::FrameNonce(header.sender, sequence);
  crypto_aead_chacha20poly1305_ietf_encrypt_detached(out.data() + sw::kFrameHeaderSize,
                                                     out.data() + sw::kFrameHeaderSize + plain_size, nullptr,
                                                     secrets_->plaintext.data(), plain_size, out.data(),
                                                     sw::kFrameHeaderSize, nullptr, nonce.data(), current.tx.data());
  current.next_tx_sequence = sequence + 1;
  ++counters_.sealed;
  return total;
}

}  // namespace teleop::transport
