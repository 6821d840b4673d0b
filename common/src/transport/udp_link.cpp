#include "teleop/transport/udp_link.hpp"

#include <netinet/in.h>

#include <array>
#include <cstring>
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

namespace teleop::transport {
namespace {

namespace asio = boost::asio;
using asio::ip::udp;

// Longer than any valid sample, so an oversized datagram is read (truncated) as more than a sample and rejected
// as kBadLength instead of being mistaken for a shorter valid one.
constexpr std::size_t kMaxSampleBytes =
    proto::wire::kHeaderSize + proto::kMaxWireDof * proto::wire::kBytesPerDof + proto::wire::kCrcSize;
constexpr std::size_t kReceiveBufferBytes = 512;
static_assert(kReceiveBufferBytes > kMaxSampleBytes);

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
// port and address bytes of the raw sockaddr. The IPv6 flow label and scope are ignored.
bool SameEndpoint(const udp::endpoint& a, const udp::endpoint& b) noexcept {
  if (a.size() != b.size()) return false;
  if (a.size() == sizeof(sockaddr_in)) {
    sockaddr_in x{};
    sockaddr_in y{};
    std::memcpy(&x, a.data(), sizeof x);
    std::memcpy(&y, b.data(), sizeof y);
    return x.sin_family == y.sin_family && x.sin_port == y.sin_port && x.sin_addr.s_addr == y.sin_addr.s_addr;
  }
  if (a.size() == sizeof(sockaddr_in6)) {
    sockaddr_in6 x{};
    sockaddr_in6 y{};
    std::memcpy(&x, a.data(), sizeof x);
    std::memcpy(&y, b.data(), sizeof y);
    return x.sin6_family == y.sin6_family && x.sin6_port == y.sin6_port &&
           std::memcmp(&x.sin6_addr, &y.sin6_addr, sizeof x.sin6_addr) == 0;
  }
  return false;
}

}  // namespace

struct UdpLink::Impl {
  explicit Impl(const UdpLinkConfig& config) : intake(config.expected_peer) {}

  asio::io_context io;
  udp::socket socket{io};
  udp::endpoint local;
  udp::endpoint peer;
  bool has_peer = false;
  bool accept_only_peer = true;
  detail::SampleIntake intake;
  udp::endpoint source;  // written by receive_from
  std::array<std::uint8_t, kMaxSampleBytes> tx{};
  std::array<std::uint8_t, kReceiveBufferBytes> rx{};
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
  if (config.receive_buffer_bytes > 0) {
    impl_->socket.set_option(asio::socket_base::receive_buffer_size(config.receive_buffer_bytes), ec);
    if (ec) {
      throw Error("UDP link on " + where + ": cannot set SO_RCVBUF to " + std::to_string(config.receive_buffer_bytes) +
                  " bytes: " + ec.message());
    }
  }
  impl_->local = impl_->socket.local_endpoint(ec);
  if (ec) throw Error("UDP link: cannot read the local address of " + where + ": " + ec.message());
  impl_->accept_only_peer = config.accept_only_peer_address;
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
}

bool UdpLink::Send(const proto::SampleMessage& message) noexcept {
  const std::size_t size = proto::EncodeSample(message, impl_->tx);
  if (size == 0 || !impl_->has_peer) {
    ++counters_.send_errors;
    return false;
  }
  boost::system::error_code ec;
  const std::size_t sent = impl_->socket.send_to(asio::buffer(impl_->tx.data(), size), impl_->peer, 0, ec);
  if (ec || sent != size) {
    ++counters_.send_errors;
    return false;
  }
  ++counters_.sent;
  return true;
}

// The one throw clang-tidy finds below is asio's endpoint::resize() inside receive_from, for a source address
// longer than sockaddr_storage, which the kernel never returns.
bool UdpLink::Poll(proto::SampleMessage& newest) noexcept {  // NOLINT(bugprone-exception-escape)
  detail::SampleIntake& intake = impl_->intake;
  intake.Begin();
  for (int i = 0; i < kMaxDatagramsPerPoll; ++i) {
    boost::system::error_code ec;
    const std::size_t size = impl_->socket.receive_from(asio::buffer(impl_->rx), impl_->source, 0, ec);
    if (ec == asio::error::would_block || ec == asio::error::try_again) break;
    if (ec) {
      // E.g. ECONNREFUSED reported for an earlier send: a medium fault, not a datagram.
      ++counters_.bus_errors;
      continue;
    }
    if (impl_->accept_only_peer && (!impl_->has_peer || !SameEndpoint(impl_->source, impl_->peer))) {
      intake.OfferForeign(counters_);
      continue;
    }
    intake.Offer(std::span<const std::uint8_t>(impl_->rx.data(), size), counters_);
  }
  return intake.Finish(newest, counters_);
}

std::string UdpLink::Describe() const {
  std::string text = "udp " + ToString(impl_->local) + " -> " + (impl_->has_peer ? ToString(impl_->peer) : "?");
  text += std::string(" (expects ") + proto::ToString(impl_->intake.expected_peer()) +
          (impl_->accept_only_peer ? ", peer address only)" : ", any address)");
  return text;
}

std::uint16_t UdpLink::local_port() const noexcept { return impl_->local.port(); }

}  // namespace teleop::transport
