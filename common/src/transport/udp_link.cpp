#include "teleop/transport/udp_link.hpp"

#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/uio.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <ctime>
// Asio trips -Wnull-dereference in its own inlined scheduler code (GCC 12, -O2); not ours to fix.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/udp.hpp>
#pragma GCC diagnostic pop
#include <string>
#include <system_error>

#include "sample_intake.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/secure_key_file.hpp"
#include "teleop/transport/secure_session.hpp"

namespace teleop::transport {
namespace {

namespace asio = boost::asio;
using asio::ip::udp;

// Longer than any valid sample, so an oversized datagram is read (truncated) as more than a sample and rejected
// as kBadLength instead of being mistaken for a shorter valid one.
constexpr std::size_t kMaxSampleBytes = proto::kMaxEncodedSampleBytes;
constexpr std::size_t kReceiveBufferBytes = 1024;  // 12 DOF with the energy block sealed: 564
static_assert(kReceiveBufferBytes > kMaxSampleBytes);
static_assert(kReceiveBufferBytes > proto::kMaxSecureMessageSize);
constexpr std::size_t kTransmitBufferBytes = std::max(kMaxSampleBytes, proto::kMaxSecureMessageSize);

std::string ToString(const udp::endpoint& endpoint) {
  const asio::ip::address address = endpoint.address();
  const std::string host = address.is_v6() ? "[" + address.to_string() + "]" : address.to_string();
  return host + ":" + std::to_string(endpoint.port());
}

asio::ip::address ParseAddress(const std::string& text, const char* what) {
  boost::system::error_code ec;
  asio::ip::address address = asio::ip::make_address(text, ec);
  if (ec) {
    throw Error(std::string("UDP link: ") + what + " '" + text +
                "' is not an IPv4 or IPv6 address literal (e.g. 127.0.0.1 or ::1; host names are not resolved)");
  }
  return address;
}

// Source check without building asio::ip::address objects (whose constructors are not noexcept): compares family,
// port and address bytes of the raw sockaddr recvmsg wrote against the peer's. The IPv6 flow label and scope are
// ignored.
bool SameEndpoint(const sockaddr_storage& source, socklen_t length, const udp::endpoint& peer) noexcept {
  if (length != peer.size()) return false;
  if (source.ss_family == AF_INET && length == sizeof(sockaddr_in)) {
    sockaddr_in x{};
    sockaddr_in y{};
    std::memcpy(&x, &source, sizeof x);
    std::memcpy(&y, peer.data(), sizeof y);
    return x.sin_family == y.sin_family && x.sin_port == y.sin_port && x.sin_addr.s_addr == y.sin_addr.s_addr;
  }
  if (source.ss_family == AF_INET6 && length == sizeof(sockaddr_in6)) {
    sockaddr_in6 x{};
    sockaddr_in6 y{};
    std::memcpy(&x, &source, sizeof x);
    std::memcpy(&y, peer.data(), sizeof y);
    return x.sin6_family == y.sin6_family && x.sin6_port == y.sin6_port &&
           std::memcmp(&x.sin6_addr, &y.sin6_addr, sizeof x.sin6_addr) == 0;
  }
  return false;
}

constexpr std::int64_t kNsPerS = 1'000'000'000;

std::int64_t NowNs(clockid_t clock) noexcept {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * kNsPerS + ts.tv_nsec;
}

// Asked for when the config leaves SO_RCVBUF at 0: a flood (or a stall of the loop) then overflows later. The
// kernel caps SO_RCVBUF at net.core.rmem_max; SO_RCVBUFFORCE (CAP_NET_ADMIN) is tried first.
constexpr int kDefaultReceiveBufferBytes = 4 * 1024 * 1024;

// Room for one SCM_TIMESTAMPNS (a timespec) and slack for anything else the kernel attaches.
constexpr std::size_t kControlBytes = CMSG_SPACE(sizeof(timespec)) + 64;

}  // namespace

struct UdpLink::Impl {
  explicit Impl(const UdpLinkConfig& config) : intake(config.expected_peer) {}

  asio::io_context io;
  udp::socket socket{io};
  udp::endpoint local;
  udp::endpoint peer;
  bool has_peer = false;
  bool accept_only_peer = true;
  bool connected = false;        ///< connect()ed to the peer: the kernel drops datagrams from any other source.
  int receive_buffer_bytes = 0;  ///< SO_RCVBUF as the kernel reports it (it doubles what is asked).
  detail::SampleIntake intake;
  std::array<std::uint8_t, kTransmitBufferBytes> tx{};
  // Authenticated mode only (security.mode kPsk).
  std::unique_ptr<SecureSession> session;
  bool initiator = false;  ///< The master drives the handshake.
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> reply{};
  proto::SampleMessage opened{};    ///< The sample Receive() decrypted.
  std::uint64_t session_id = 0;     ///< The session the sequence tracker belongs to.
  std::int64_t next_hello_ns = 0;   ///< Master: no hello before this (handshake_retry_ms apart).
  std::int64_t last_sample_ns = 0;  ///< Newest authenticated sample or session start (monotonic).
  std::int64_t retry_ns = 0;
  std::int64_t silence_ns = 0;
  std::array<std::uint8_t, kReceiveBufferBytes> rx{};
  alignas(cmsghdr) std::array<std::uint8_t, kControlBytes> control{};
  sockaddr_storage source{};  // written by recvmsg
};

UdpLink::UdpLink(const UdpLinkConfig& config) : impl_(std::make_unique<Impl>(config)) {
  const udp::endpoint bind_endpoint(ParseAddress(config.bind_address, "bind_address"), config.bind_port);
  const std::string where = ToString(bind_endpoint);
  boost::system::error_code ec;
  impl_->socket.open(bind_endpoint.protocol(), ec);
  if (ec) throw Error("UDP link: cannot open a socket for " + where + ": " + ec.message());
  impl_->socket.bind(bind_endpoint, ec);
  if (ec) {
    throw Error("UDP link: cannot bind to " + where + ": " + ec.message() +
                " (is another teleop process using this port? is the address one of this host's? choose another "
                "link bind address or port)");
  }
  impl_->socket.non_blocking(true, ec);
  if (ec) throw Error("UDP link: cannot make the socket on " + where + " non-blocking: " + ec.message());
  if (config.receive_buffer_bytes < 0) {
    throw Error("UDP link on " + where + ": receive_buffer_bytes must be >= 0 (0 = kernel default), got " +
                std::to_string(config.receive_buffer_bytes));
  }
  const int fd = impl_->socket.native_handle();
  if (config.receive_buffer_bytes > 0) {
    impl_->socket.set_option(asio::socket_base::receive_buffer_size(config.receive_buffer_bytes), ec);
    if (ec) {
      throw Error("UDP link on " + where + ": cannot set SO_RCVBUF to " + std::to_string(config.receive_buffer_bytes) +
                  " bytes: " + ec.message());
    }
  } else if (setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &kDefaultReceiveBufferBytes,
                        sizeof kDefaultReceiveBufferBytes) != 0) {
    // Best effort without CAP_NET_ADMIN: capped at net.core.rmem_max, which Describe() then shows.
    (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &kDefaultReceiveBufferBytes, sizeof kDefaultReceiveBufferBytes);
  }
  socklen_t length = sizeof impl_->receive_buffer_bytes;
  if (getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &impl_->receive_buffer_bytes, &length) != 0) {
    throw Error("UDP link on " + where + ": cannot read SO_RCVBUF back: " + std::strerror(errno));
  }
  // Kernel receive timestamps (CLOCK_REALTIME, ns) on every datagram, read with recvmsg in Poll.
  const int on = 1;
  if (setsockopt(impl_->socket.native_handle(), SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) != 0) {
    throw Error("UDP link on " + where + ": cannot enable SO_TIMESTAMPNS: " + std::strerror(errno));
  }
  if (config.busy_poll_us < 0 || config.spin_poll_us < 0) {
    throw Error("UDP link on " + where + ": busy_poll_us and spin_poll_us must be >= 0 (0 = off), got " +
                std::to_string(config.busy_poll_us) + " and " + std::to_string(config.spin_poll_us));
  }
  if (config.busy_poll_us > 0) {
    // Not permitted without CAP_NET_ADMIN above net.core.busy_read: the link then runs without it.
    busy_poll_applied_ = setsockopt(impl_->socket.native_handle(), SOL_SOCKET, SO_BUSY_POLL, &config.busy_poll_us,
                                    sizeof config.busy_poll_us) == 0;
  }
  busy_poll_us_ = config.busy_poll_us;
  spin_poll_ns_ = static_cast<std::int64_t>(config.spin_poll_us) * 1000;
  impl_->local = impl_->socket.local_endpoint(ec);
  if (ec) throw Error("UDP link: cannot read the local address of " + where + ": " + ec.message());
  impl_->accept_only_peer = config.accept_only_peer_address;
  if (config.security.mode == LinkSecurityMode::kPsk) {
    const LinkSecurityConfig& security = config.security;
    if (!std::isfinite(security.handshake_retry_ms) || security.handshake_retry_ms <= 0.0 ||
        !std::isfinite(config.peer_silence_ms) || config.peer_silence_ms <= 0.0) {
      throw Error("UDP link on " + where + ": handshake_retry_ms and peer_silence_ms must be finite and > 0");
    }
    SecureSessionConfig session = security.session;
    session.role = proto::PeerOf(config.expected_peer);
    session.offload_key_exchange = true;  // X25519 on the session's helper thread, never in the cycle
    impl_->session = std::make_unique<SecureSession>(session, LoadPreSharedKey(security.key_file));
    impl_->initiator = session.role == proto::SenderRole::kMaster;
    impl_->retry_ns = static_cast<std::int64_t>(security.handshake_retry_ms * 1e6);
    impl_->silence_ns = static_cast<std::int64_t>(config.peer_silence_ms * 1e6);
  }
  if (config.peer_port != 0) SetPeer(config.peer_address, config.peer_port);
}

UdpLink::~UdpLink() = default;

void UdpLink::SetPeer(const std::string& address, std::uint16_t port) {
  const asio::ip::address parsed = ParseAddress(address, "peer_address");
  if (port == 0) throw Error("UDP link: peer port for " + address + " must be 1..65535, got 0");
  if (parsed.is_v6() != impl_->local.address().is_v6()) {
    throw Error("UDP link: peer " + address + " and bind address " + impl_->local.address().to_string() +
                " are of different families (IPv4 vs IPv6); use the same family for both");
  }
  impl_->peer = udp::endpoint(parsed, port);
  impl_->has_peer = true;
  if (impl_->accept_only_peer) {
    // The kernel then delivers only the peer's datagrams: other sources never reach the queue or the session.
    boost::system::error_code ec;
    impl_->socket.connect(impl_->peer, ec);
    if (ec)
      throw Error("UDP link: cannot connect the socket to the peer " + ToString(impl_->peer) + ": " + ec.message());
    impl_->connected = true;
  }
}

bool UdpLink::SendBytes(const std::uint8_t* bytes, std::size_t size) noexcept {
  // On a connected socket an ICMP "port unreachable" for an earlier datagram (the peer not started yet) is reported
  // by the next send, which then sends nothing: once more, so that one report does not cost a datagram.
  for (int attempt = 0; attempt < 2; ++attempt) {
    const ssize_t sent = impl_->connected ? ::send(impl_->socket.native_handle(), bytes, size, MSG_DONTWAIT)
                                          : ::sendto(impl_->socket.native_handle(), bytes, size, MSG_DONTWAIT,
                                                     impl_->peer.data(), static_cast<socklen_t>(impl_->peer.size()));
    if (sent == static_cast<ssize_t>(size)) return true;
    if (sent >= 0 || errno != ECONNREFUSED) return false;
  }
  return false;
}

bool UdpLink::Send(const proto::SampleMessage& message) noexcept {
  std::size_t size = 0;
  if (impl_->session) {
    size = impl_->session->Seal(message, impl_->tx);
    if (size == 0 && impl_->session->session_id() == 0) {
      ++counters_.send_no_session;  // not connected yet: nothing to send, not a medium error
      return false;
    }
  } else {
    size = proto::EncodeSample(message, impl_->tx);
  }
  if (size == 0 || !impl_->has_peer) {
    ++counters_.send_errors;
    return false;
  }
  if (!SendBytes(impl_->tx.data(), size)) {
    ++counters_.send_errors;
    return false;
  }
  ++counters_.sent;
  return true;
}

bool UdpLink::Poll(proto::SampleMessage& newest) noexcept {
  const std::int64_t deadline = spin_poll_ns_ > 0 ? NowNs(CLOCK_MONOTONIC) + spin_poll_ns_ : 0;
  return PollUntil(newest, deadline);
}

void UdpLink::SendRaw(const std::uint8_t* bytes, std::size_t size) noexcept {
  if (!impl_->has_peer) return;
  if (!SendBytes(bytes, size)) ++counters_.send_errors;
}

void UdpLink::DriveHandshake(std::int64_t now_ns) noexcept {
  Impl& s = *impl_;
  if (!s.session || !s.initiator || !s.has_peer) return;
  const bool established = s.session->session_id() != 0;
  if (established && now_ns - s.last_sample_ns <= s.silence_ns) return;
  if (now_ns < s.next_hello_ns) return;
  // The key pair is made ahead by the session's helper thread: until it is there, ask again next cycle rather than
  // do the X25519 here (counters().key_pairs_inline stays 0).
  if (!s.session->HelloReady()) return;
  s.next_hello_ns = now_ns + s.retry_ns;
  const std::size_t size = s.session->BeginHandshake(s.reply);
  if (size > 0) SendRaw(s.reply.data(), size);
  counters_.handshakes_started = s.session->counters().handshakes_started;
}

void UdpLink::NoteSession(std::int64_t now_ns) noexcept {
  Impl& s = *impl_;
  counters_.handshakes_started = s.session->counters().handshakes_started;
  const std::uint64_t id = s.session->session_id();
  if (id != 0 && id != s.session_id) {
    // A new session (first one, peer restart, re-handshake): its sequence starts again at 0.
    s.session_id = id;
    ++counters_.sessions;
    s.intake.DropPending(counters_);
    s.intake.ResetTracker();
    s.last_sample_ns = now_ns;
  }
}

void UdpLink::PumpSession(std::int64_t now_ns) noexcept {
  Impl& s = *impl_;
  // A key exchange the session's helper thread finished: send the welcome (slave) or confirm (master) now.
  const std::size_t size = s.session->Pump(s.reply);
  if (size > 0) SendRaw(s.reply.data(), size);
  NoteSession(now_ns);
}

bool UdpLink::OfferSecure(std::size_t length, std::int64_t now_ns) noexcept {
  Impl& s = *impl_;
  const SecureReceiveResult result = s.session->Receive(std::span<const std::uint8_t>(s.rx.data(), length),
                                                        static_cast<std::uint64_t>(now_ns), s.reply, s.opened);
  if (result.reply_size > 0) SendRaw(s.reply.data(), result.reply_size);
  NoteSession(now_ns);
  switch (result.status) {
    case SecureReceiveStatus::kSample:
      s.last_sample_ns = now_ns;
      return s.intake.OfferDecoded(s.opened, counters_) == SequenceTracker::Verdict::kNewer;
    case SecureReceiveStatus::kHandshake:
      s.intake.OfferHandshake(counters_);
      return false;
    default:
      s.intake.RejectSecure(result.status, std::span<const std::uint8_t>(s.rx.data(), length), counters_);
      return false;
  }
}

bool UdpLink::PollUntil(proto::SampleMessage& newest, std::int64_t deadline_ns) noexcept {
  if (impl_->session) {
    const std::int64_t now = NowNs(CLOCK_MONOTONIC);
    PumpSession(now);
    if (impl_->initiator) DriveHandshake(now);
  }
  while (true) {
    // The offset between the kernel's clock (realtime) and the loop's (monotonic), read once per drain.
    const std::int64_t monotonic = NowNs(CLOCK_MONOTONIC);
    const std::int64_t realtime = NowNs(CLOCK_REALTIME);
    if (PollOnce(newest, monotonic, realtime - monotonic)) return true;
    if (monotonic >= deadline_ns) return false;
  }
}

bool UdpLink::PollOnce(proto::SampleMessage& newest, std::int64_t poll_monotonic_ns,
                       std::int64_t realtime_minus_monotonic_ns) noexcept {
  detail::SampleIntake& intake = impl_->intake;
  const int fd = impl_->socket.native_handle();
  intake.Begin();
  std::int64_t pending_time = 0;
  bool pending_from_kernel = false;
  for (int i = 0; i < kMaxDatagramsPerPoll; ++i) {
    iovec iov{impl_->rx.data(), impl_->rx.size()};
    msghdr message{};
    message.msg_name = &impl_->source;
    message.msg_namelen = sizeof impl_->source;
    message.msg_iov = &iov;
    message.msg_iovlen = 1;
    message.msg_control = impl_->control.data();
    message.msg_controllen = impl_->control.size();
    const ssize_t size = recvmsg(fd, &message, MSG_DONTWAIT);
    if (size < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) break;
      if (errno == EINTR) continue;
      // E.g. ECONNREFUSED reported for an earlier send: a medium fault, not a datagram.
      ++counters_.bus_errors;
      continue;
    }
    if (impl_->accept_only_peer &&
        (!impl_->has_peer || !SameEndpoint(impl_->source, message.msg_namelen, impl_->peer))) {
      intake.OfferForeign(counters_);
      continue;
    }
    // A truncated datagram (longer than the buffer) is offered at the buffer's length: more than any sample, so
    // it is rejected as kBadLength.
    const std::size_t length = std::min(static_cast<std::size_t>(size), impl_->rx.size());
    const bool newest_of_drain = impl_->session
                                     ? OfferSecure(length, poll_monotonic_ns)
                                     : intake.Offer(std::span<const std::uint8_t>(impl_->rx.data(), length), counters_);
    if (!newest_of_drain) continue;
    pending_time = poll_monotonic_ns;
    pending_from_kernel = false;
    for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr; c = CMSG_NXTHDR(&message, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS && c->cmsg_len >= CMSG_LEN(sizeof(timespec))) {
        timespec stamp{};
        std::memcpy(&stamp, CMSG_DATA(c), sizeof stamp);
        const std::int64_t realtime_ns = static_cast<std::int64_t>(stamp.tv_sec) * kNsPerS + stamp.tv_nsec;
        // Realtime → monotonic; never later than this Poll (a realtime step backwards could claim otherwise).
        pending_time = std::min(realtime_ns - realtime_minus_monotonic_ns, poll_monotonic_ns);
        pending_from_kernel = true;
      }
    }
  }
  if (!intake.Finish(newest, counters_)) return false;
  newest_receive_time_ns_ = pending_time;
  newest_from_kernel_ = pending_from_kernel;
  return true;
}

bool UdpLink::WaitReadable(std::int64_t deadline_ns) noexcept {
  pollfd descriptor{impl_->socket.native_handle(), POLLIN, 0};
  const std::int64_t remaining = std::max<std::int64_t>(deadline_ns - NowNs(CLOCK_MONOTONIC), 0);
  const timespec timeout{static_cast<time_t>(remaining / kNsPerS), static_cast<long>(remaining % kNsPerS)};
  return ppoll(&descriptor, 1, &timeout, nullptr) > 0 && (descriptor.revents & POLLIN) != 0;
}

std::string UdpLink::Describe() const {
  std::string text = "udp " + ToString(impl_->local) + " -> " + (impl_->has_peer ? ToString(impl_->peer) : "?");
  text += std::string(" (expects ") + proto::ToString(impl_->intake.expected_peer()) +
          (impl_->accept_only_peer ? ", peer address only" : ", any address") +
          (impl_->connected ? ", connected" : "") + ", rcvbuf " + std::to_string(impl_->receive_buffer_bytes) + " B" +
          (impl_->session ? ", authenticated: psk" : ", INSECURE: no authentication") +
          (busy_poll_us_ == 0   ? ")"
           : busy_poll_applied_ ? ", busy poll " + std::to_string(busy_poll_us_) + " us)"
                                : ", busy poll " + std::to_string(busy_poll_us_) + " us REFUSED by the kernel)");
  return text;
}

std::uint16_t UdpLink::local_port() const noexcept { return impl_->local.port(); }

int UdpLink::receive_buffer_bytes() const noexcept { return impl_->receive_buffer_bytes; }

bool UdpLink::connected() const noexcept { return impl_->connected; }

}  // namespace teleop::transport
