#include "teleop/transport/secure_session.hpp"

#include <sodium.h>

#include <cmath>
#include <string>

#include "teleop/error.hpp"
#include "teleop/proto/codec.hpp"

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
      psk_(key),
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
  if (sodium_is_zero(psk_.bytes().data(), psk_.bytes().size()) == 1) {
    throw Error("secure session: the pre-shared key is all zero");
  }
  crypto_kdf_derive_from_key(handshake_key_.data(), handshake_key_.size(), kSubkeyHandshake, kHandshakeContext,
                             psk_.bytes().data());
}

SecureSession::~SecureSession() {
  Wipe(current_);
  Wipe(pending_);
  sodium_memzero(handshake_key_.data(), handshake_key_.size());
  sodium_memzero(ephemeral_secret_.data(), ephemeral_secret_.size());
  sodium_memzero(plaintext_.data(), plaintext_.size());
}

void SecureSession::Wipe(Keys& keys) noexcept {
  sodium_memzero(keys.tx.data(), keys.tx.size());
  sodium_memzero(keys.rx.data(), keys.rx.size());
  sodium_memzero(keys.confirm.data(), keys.confirm.size());
  keys = Keys{};
}

SecureSessionState SecureSession::state() const noexcept {
  if (current_.active) return SecureSessionState::kEstablished;
  if (handshaking_ || pending_.active) return SecureSessionState::kHandshaking;
  return SecureSessionState::kNoSession;
}

SecureReceiveResult SecureSession::Count(SecureReceiveResult result) noexcept {
  ++counters_.by_status[static_cast<std::size_t>(result.status)];
  return result;
}

std::size_t SecureSession::BeginHandshake(std::span<std::uint8_t> out) noexcept {
  if (config_.role != proto::SenderRole::kMaster || out.size() < sw::kKeyExchangeSize) return 0;
  randombytes_buf(ephemeral_secret_.data(), ephemeral_secret_.size());
  if (crypto_scalarmult_base(ephemeral_public_.data(), ephemeral_secret_.data()) != 0) return 0;
  proto::KeyExchangeMessage hello{};
  hello.type = proto::SecureMessageType::kHello;
  hello.sender = config_.role;
  hello.ephemeral_key = ephemeral_public_;
  if (proto::EncodeKeyExchange(hello, hello_) != sw::kKeyExchangeSize) return 0;
  Mac(handshake_key_.data(), std::span(hello_).first(sw::kKeyExchangeTagOffset), {},
      hello_.data() + sw::kKeyExchangeTagOffset);
  std::copy(hello_.begin(), hello_.end(), out.begin());
  handshaking_ = true;
  ++counters_.handshakes_started;
  return sw::kKeyExchangeSize;
}

// secret = BLAKE2b-256(key = PSK, X25519(own, peer) ‖ hello ‖ welcome); the session keys and id are KDF subkeys of
// it. Mixing the PSK in (as Noise's psk modes and WireGuard do) means even a broken MAC check could not let a party
// without the PSK derive the keys; the transcript binds the keys to this exchange.
bool SecureSession::DeriveKeys(const std::uint8_t* own_secret, const std::uint8_t* peer_public, Keys& out) noexcept {
  std::array<std::uint8_t, crypto_scalarmult_BYTES> shared{};
  if (crypto_scalarmult(shared.data(), own_secret, peer_public) != 0) return false;  // low-order point
  std::array<std::uint8_t, crypto_kdf_KEYBYTES> secret{};
  crypto_generichash_state state;
  crypto_generichash_init(&state, psk_.bytes().data(), psk_.bytes().size(), secret.size());
  crypto_generichash_update(&state, shared.data(), shared.size());
  crypto_generichash_update(&state, hello_.data(), hello_.size());
  crypto_generichash_update(&state, welcome_.data(), welcome_.size());
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
  if (!datagram_bucket_.TryTake(now_ns)) return Count({SecureReceiveStatus::kRateLimited});
  const proto::DatagramKind kind = proto::ClassifyDatagram(datagram);
  if (kind.status != proto::DecodeStatus::kOk) return Count({SecureReceiveStatus::kMalformed});
  if (kind.version == proto::kProtocolVersion) return Count({SecureReceiveStatus::kInsecure});
  if (kind.version != proto::kSecureProtocolVersion) return Count({SecureReceiveStatus::kMalformed});
  switch (static_cast<proto::SecureMessageType>(kind.type)) {
    case proto::SecureMessageType::kFrame:
      return Count(OnFrame(datagram, sample));
    case proto::SecureMessageType::kHello:
    case proto::SecureMessageType::kWelcome:
      if (!handshake_bucket_.TryTake(now_ns)) return Count({SecureReceiveStatus::kHandshakeRateLimited});
      return Count(kind.type == static_cast<std::uint8_t>(proto::SecureMessageType::kHello)
                       ? OnHello(datagram, reply)
                       : OnWelcome(datagram, reply));
    case proto::SecureMessageType::kConfirm:
      return Count(OnConfirm(datagram));
  }
  return Count({SecureReceiveStatus::kMalformed});
}

SecureReceiveResult SecureSession::OnHello(std::span<const std::uint8_t> datagram,
                                           std::span<std::uint8_t> reply) noexcept {
  proto::KeyExchangeMessage hello{};
  if (proto::DecodeKeyExchange(datagram, hello) != proto::DecodeStatus::kOk) return {SecureReceiveStatus::kMalformed};
  if (hello.sender != peer_) return {SecureReceiveStatus::kWrongSender};
  if (config_.role != proto::SenderRole::kSlave) return {SecureReceiveStatus::kUnexpectedHandshake};
  if (reply.size() < sw::kKeyExchangeSize) return {SecureReceiveStatus::kUnexpectedHandshake};
  if (!MacMatches(handshake_key_.data(), datagram.first(sw::kKeyExchangeTagOffset), {}, hello.tag.data())) {
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  // A valid hello starts a new pending session; the established one (if any) keeps working until the initiator
  // proves it holds the new keys (confirm or first frame). So a replayed hello costs one welcome, nothing else.
  std::copy(datagram.begin(), datagram.end(), hello_.begin());
  randombytes_buf(ephemeral_secret_.data(), ephemeral_secret_.size());
  if (crypto_scalarmult_base(ephemeral_public_.data(), ephemeral_secret_.data()) != 0) {
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  proto::KeyExchangeMessage welcome{};
  welcome.type = proto::SecureMessageType::kWelcome;
  welcome.sender = config_.role;
  welcome.ephemeral_key = ephemeral_public_;
  if (proto::EncodeKeyExchange(welcome, welcome_) != sw::kKeyExchangeSize) return {SecureReceiveStatus::kMalformed};
  Mac(handshake_key_.data(), hello_, std::span(welcome_).first(sw::kKeyExchangeTagOffset),
      welcome_.data() + sw::kKeyExchangeTagOffset);
  Keys derived{};
  if (!DeriveKeys(ephemeral_secret_.data(), hello.ephemeral_key.data(), derived)) {
    Wipe(derived);
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  sodium_memzero(ephemeral_secret_.data(), ephemeral_secret_.size());
  Wipe(pending_);
  pending_ = derived;
  Wipe(derived);
  std::copy(welcome_.begin(), welcome_.end(), reply.begin());
  ++counters_.handshakes_started;
  return {SecureReceiveStatus::kHandshake, sw::kKeyExchangeSize};
}

SecureReceiveResult SecureSession::OnWelcome(std::span<const std::uint8_t> datagram,
                                             std::span<std::uint8_t> reply) noexcept {
  proto::KeyExchangeMessage welcome{};
  if (proto::DecodeKeyExchange(datagram, welcome) != proto::DecodeStatus::kOk) {
    return {SecureReceiveStatus::kMalformed};
  }
  if (welcome.sender != peer_) return {SecureReceiveStatus::kWrongSender};
  if (config_.role != proto::SenderRole::kMaster || !handshaking_) return {SecureReceiveStatus::kUnexpectedHandshake};
  if (reply.size() < sw::kConfirmSize) return {SecureReceiveStatus::kUnexpectedHandshake};
  if (!MacMatches(handshake_key_.data(), hello_, datagram.first(sw::kKeyExchangeTagOffset), welcome.tag.data())) {
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  std::copy(datagram.begin(), datagram.end(), welcome_.begin());
  Keys derived{};
  if (!DeriveKeys(ephemeral_secret_.data(), welcome.ephemeral_key.data(), derived)) {
    Wipe(derived);
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  proto::ConfirmMessage confirm{};
  confirm.sender = config_.role;
  confirm.session_id = derived.id;
  if (proto::EncodeConfirm(confirm, reply) != sw::kConfirmSize) {
    Wipe(derived);
    return {SecureReceiveStatus::kMalformed};
  }
  Mac(derived.confirm.data(), reply.first(sw::kConfirmTagOffset), {}, reply.data() + sw::kConfirmTagOffset);
  // The initiator switches now: the welcome proved the responder holds the PSK and answered this very hello.
  sodium_memzero(ephemeral_secret_.data(), ephemeral_secret_.size());
  handshaking_ = false;
  Wipe(current_);
  current_ = derived;
  Wipe(derived);
  ++counters_.sessions_established;
  return {SecureReceiveStatus::kHandshake, sw::kConfirmSize};
}

SecureReceiveResult SecureSession::OnConfirm(std::span<const std::uint8_t> datagram) noexcept {
  proto::ConfirmMessage confirm{};
  if (proto::DecodeConfirm(datagram, confirm) != proto::DecodeStatus::kOk) return {SecureReceiveStatus::kMalformed};
  if (confirm.sender != peer_) return {SecureReceiveStatus::kWrongSender};
  if (config_.role != proto::SenderRole::kSlave) return {SecureReceiveStatus::kUnexpectedHandshake};
  if (!pending_.active || confirm.session_id != pending_.id) {
    // A late duplicate of the confirm that established the current session is harmless, still not acted on.
    return {SecureReceiveStatus::kUnexpectedHandshake};
  }
  if (!MacMatches(pending_.confirm.data(), datagram.first(sw::kConfirmTagOffset), {}, confirm.tag.data())) {
    return {SecureReceiveStatus::kBadHandshakeTag};
  }
  Wipe(current_);
  current_ = pending_;
  Wipe(pending_);
  ++counters_.sessions_established;
  return {SecureReceiveStatus::kHandshake};
}

SecureReceiveResult SecureSession::OnFrame(std::span<const std::uint8_t> datagram,
                                           proto::SampleMessage& sample) noexcept {
  proto::SecureFrameView frame{};
  if (proto::DecodeSecureFrame(datagram, frame) != proto::DecodeStatus::kOk) return {SecureReceiveStatus::kMalformed};
  if (frame.header.sender != peer_) return {SecureReceiveStatus::kWrongSender};
  Keys* keys = nullptr;
  if (current_.active && frame.header.session_id == current_.id) {
    keys = &current_;
  } else if (pending_.active && frame.header.session_id == pending_.id) {
    keys = &pending_;
  } else {
    return {current_.active || pending_.active ? SecureReceiveStatus::kWrongSession : SecureReceiveStatus::kNoSession};
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
          plaintext_.data(), nullptr, frame.ciphertext.data(), frame.ciphertext.size(), frame.tag.data(),
          frame.associated_data.data(), frame.associated_data.size(), nonce.data(), keys->rx.data()) != 0) {
    return {SecureReceiveStatus::kBadTag};
  }
  if (keys == &pending_) {
    // First authentic frame of the pending session: the initiator holds its keys (its confirm was lost or is late).
    Wipe(current_);
    current_ = pending_;
    Wipe(pending_);
    keys = &current_;
    ++counters_.sessions_established;
  }
  const bool newest = keys->window.Mark(frame.header.sequence);
  proto::SampleMessage decoded{};
  const auto plain = std::span<const std::uint8_t>(plaintext_).first(frame.ciphertext.size());
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
  if (!current_.active || sample.sender != config_.role || sample.dof != config_.dof) {
    ++counters_.seal_refused;
    return 0;
  }
  const std::size_t plain_size = proto::EncodedSampleSize(sample.dof, sample.has_energy);
  const std::size_t total = sw::kFrameHeaderSize + plain_size + proto::kFrameTagBytes;
  if (out.size() < total) {
    ++counters_.seal_refused;
    return 0;
  }
  const std::uint64_t sequence = current_.next_tx_sequence;
  proto::SampleMessage inner = sample;
  inner.sequence = static_cast<std::uint32_t>(sequence);
  if (proto::EncodeSample(inner, plaintext_) != plain_size) {
    ++counters_.seal_refused;
    return 0;
  }
  proto::SecureFrameHeader header{};
  header.sender = config_.role;
  header.session_id = current_.id;
  header.sequence = sequence;
  header.sealed_length = static_cast<std::uint16_t>(plain_size);
  if (proto::EncodeSecureFrameHeader(header, out) != sw::kFrameHeaderSize) {
    ++counters_.seal_refused;
    return 0;
  }
  const auto nonce = proto::FrameNonce(header.sender, sequence);
  crypto_aead_chacha20poly1305_ietf_encrypt_detached(
      out.data() + sw::kFrameHeaderSize, out.data() + sw::kFrameHeaderSize + plain_size, nullptr, plaintext_.data(),
      plain_size, out.data(), sw::kFrameHeaderSize, nullptr, nonce.data(), current_.tx.data());
  current_.next_tx_sequence = sequence + 1;
  ++counters_.sealed;
  return total;
}

}  // namespace teleop::transport
