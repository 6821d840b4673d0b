#include "teleop/transport/can_udp_bus_port.hpp"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cstddef>
#include <cstring>
#include <ctime>
#include <utility>

#include "receive_timestamp.hpp"
#include "teleop/error.hpp"

namespace teleop::transport {

namespace {

bool SendMessage(int socket, const bus_datagram::Message& m) noexcept {
  std::array<std::uint8_t, bus_datagram::kMaxSize> out{};
  const std::size_t size = bus_datagram::Encode(m, out);
  return size > 0 && ::send(socket, out.data(), size, MSG_NOSIGNAL) == static_cast<ssize_t>(size);
}

}  // namespace

UdpCanBusPort::UdpCanBusPort(const std::string& host, std::uint16_t port, double timeout_ms, CanReceiveOptions options)
    : options_(std::move(options)), endpoint_(fmt::format("{}:{}", host, port)) {
  if (options_.filters.size() > kMaxCanFilters) {
    throw Error("emulated-can: " + std::to_string(options_.filters.size()) + " receive filters, at most " +
                std::to_string(kMaxCanFilters));
  }
  const bool unix_mode = host.rfind("unix:", 0) == 0;
  unix_ = unix_mode;
  if (unix_mode) {
    // A Unix-domain node: the socket file's permissions decide whether this process may send to the daemon at all
    // (connect() fails with EACCES), and the daemon reads the uid from the kernel (docs/security.md).
    endpoint_ = host;
    const std::string path = host.substr(5);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (path.empty() || path.size() >= sizeof(addr.sun_path)) {
      throw Error(
          fmt::format("emulated-can: bus socket path '{}' must be 1..{} characters", path, sizeof(addr.sun_path) - 1));
    }
    std::memcpy(addr.sun_path, path.data(), path.size());
    socket_ = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (socket_ < 0) throw Error(std::string("emulated-can: socket: ") + std::strerror(errno));
    const auto* any = reinterpret_cast<const sockaddr*>(&addr);  // NOLINT: sockets API
    int rc = ::connect(socket_, any, static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + path.size() + 1));
    if (rc != 0 && errno == EINPROGRESS) {  // a full backlog on a non-blocking socket: wait, then ask how it went
      pollfd pfd{socket_, POLLOUT, 0};
      int error = ETIMEDOUT;
      socklen_t len = sizeof error;
      if (::poll(&pfd, 1, static_cast<int>(timeout_ms)) == 1) ::getsockopt(socket_, SOL_SOCKET, SO_ERROR, &error, &len);
      errno = error;
      rc = error == 0 ? 0 : -1;
    }
    if (rc != 0) {
      const int e = errno;
      ::close(socket_);
      socket_ = -1;
      if (e == EACCES || e == EPERM) {
        throw Error(
            fmt::format("emulated-can: not allowed to join the bus at {}: {} (the socket file's mode and "
                        "group say who may; docs/security.md, \"What CAN trusts\")",
                        endpoint_, std::strerror(e)));
      }
      throw Error(fmt::format("emulated-can: no teleop-canbus at {}: {}: start it first (teleop-canbus --bind {})",
                              endpoint_, std::strerror(e), endpoint_));
    }
  } else {
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port);
    if (::inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
      throw Error("emulated-can: bus host '" + host +
                  "' is not an IPv4 address or unix:PATH (teleop-canbus listens on IPv4 or a Unix socket)");
    }
    socket_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (socket_ < 0) throw Error(std::string("emulated-can: socket: ") + std::strerror(errno));
    if (::connect(socket_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) < 0) {  // NOLINT: sockets API
      const std::string reason = std::strerror(errno);
      ::close(socket_);
      throw Error("emulated-can: connect to " + endpoint_ + ": " + reason);
    }
  }
  (void)detail::EnableReceiveTimestamps(socket_);  // else the read time stands in for the receive time
  // Attach: hello until welcome, for up to timeout_ms.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double, std::milli>(timeout_ms);
  bus_datagram::Message hello{};
  hello.type = bus_datagram::Type::kHello;
  while (node_ < 0 && std::chrono::steady_clock::now() < deadline) {
    SendMessage(socket_, hello);
    pollfd pfd{socket_, POLLIN, 0};
    ::poll(&pfd, 1, 50);
    std::array<std::uint8_t, bus_datagram::kMaxSize> in{};
    for (;;) {
      const ssize_t n = ::recv(socket_, in.data(), in.size(), 0);
      if (n <= 0) break;  // nothing, or (Unix mode) the daemon closed the connection
      bus_datagram::Message m{};
      if (bus_datagram::Decode(std::span<const std::uint8_t>(in.data(), static_cast<std::size_t>(n)), m) &&
          m.type == bus_datagram::Type::kWelcome) {
        node_ = m.node;
        break;
      }
    }
  }
  Sent();
  if (node_ < 0) {
    ::close(socket_);
    throw Error(
        fmt::format("emulated-can: no teleop-canbus answered at {} within {:g} ms: start it first (teleop-canbus {}){}",
                    endpoint_, timeout_ms, unix_mode ? "--bind " + host : fmt::format("--port {}", port),
                    unix_mode ? " (or it does not admit this user: --allow-uid)" : ""));
  }
}

UdpCanBusPort::~UdpCanBusPort() {
  if (socket_ >= 0) {
    bus_datagram::Message bye{};
    bye.type = bus_datagram::Type::kBye;
    SendMessage(socket_, bye);
    ::close(socket_);
  }
}

CanWriteStatus UdpCanBusPort::Write(const proto::can::CanFrame& frame) noexcept {
  if (frame.fd && !options_.fd) return CanWriteStatus::kError;  // as SocketCAN without FD frames
  bus_datagram::Message m{};
  m.type = bus_datagram::Type::kFrame;
  m.frame = frame;
  std::array<std::uint8_t, bus_datagram::kMaxSize> out{};
  const std::size_t size = bus_datagram::Encode(m, out);
  if (size == 0) return CanWriteStatus::kError;
  const ssize_t n = ::send(socket_, out.data(), size, MSG_NOSIGNAL);  // Unix mode: EPIPE, never SIGPIPE
  if (n == static_cast<ssize_t>(size)) {
    Sent();
    return CanWriteStatus::kOk;
  }
  if (n < 0 && (errno == EAGAIN || errno == ENOBUFS)) return CanWriteStatus::kBufferFull;
  return CanWriteStatus::kError;  // e.g. ECONNREFUSED: the daemon is gone
}

void UdpCanBusPort::Sent() noexcept {
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  last_sent_ns_ = static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

bool UdpCanBusPort::Read(proto::can::CanFrame& frame) noexcept {
  if (!unix_) {  // a node that only listens still says it is there (the daemon detaches silent UDP nodes)
    timespec now{};
    ::clock_gettime(CLOCK_MONOTONIC, &now);
    const std::int64_t now_ns = static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
    if (now_ns - last_sent_ns_ > kKeepAlive_ms * 1'000'000) {
      bus_datagram::Message hello{};
      hello.type = bus_datagram::Type::kHello;
      if (SendMessage(socket_, hello)) last_sent_ns_ = now_ns;
    }
  }
  std::array<std::uint8_t, bus_datagram::kMaxSize + 1> in{};
  for (;;) {
    std::int64_t received_ns = 0;
    const ssize_t n = detail::ReceiveStamped(socket_, in.data(), in.size(), received_ns);
    // EAGAIN, or ECONNREFUSED for an earlier send / 0 at end of connection (Unix mode): the daemon is gone.
    if (n <= 0) return false;
    bus_datagram::Message m{};
    if (bus_datagram::Decode(std::span<const std::uint8_t>(in.data(), static_cast<std::size_t>(n)), m) &&
        m.type == bus_datagram::Type::kFrame && Accepts(options_, m.frame)) {
      frame = m.frame;
      receive_time_ns_ = received_ns;
      return true;
    }
    // Late welcomes, malformed datagrams and frames the filters do not pass: skip.
  }
}

bool UdpCanBusPort::SendControl(bus_datagram::Action action, std::uint32_t argument) noexcept {
  bus_datagram::Message m{};
  m.type = bus_datagram::Type::kControl;
  m.action = action;
  m.argument = argument;
  if (!SendMessage(socket_, m)) return false;
  Sent();
  return true;
}

bool UdpCanBusPort::WaitReadable(std::int64_t deadline_ns) noexcept {
  return detail::WaitFdReadable(socket_, deadline_ns);
}

std::string UdpCanBusPort::Describe() const { return fmt::format("emulated-can {} node {}", endpoint_, node_); }

}  // namespace teleop::transport
