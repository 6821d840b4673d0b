#include "teleop/transport/can_bus_server.hpp"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <string_view>

#include "teleop/error.hpp"
#include "teleop/transport/can_bus_datagram.hpp"

namespace teleop::transport {

struct CanBusServer::Peer {
  sockaddr_storage address{};  ///< sockaddr_in (UDP) or sockaddr_un (the node's autobound abstract address).
  socklen_t address_len = 0;
  int fd = -1;  ///< Unix mode: the node's connection (seqpacket), which replies and frames go out on.
  int node = 0;
  bool local = false;  ///< A socket of this host (its owner is `uid`), not a remote node.
  std::uint32_t uid = 0;
  /// UDP, local: the inode of the socket that said hello. The node is that socket, not its port: when another
  /// socket holds the address (its owner died and someone bound the freed port) the node is detached.
  std::uint64_t inode = 0;
  std::uint64_t last_heard_ns = 0;  ///< UDP: the newest datagram from it (a silent node is detached).
};

/// Where a message came from: a UDP source address, or (Unix mode) a connection and the uid the kernel gave it.
struct CanBusServer::From {
  const sockaddr_storage* address = nullptr;
  socklen_t address_len = 0;
  int fd = -1;
  std::uint32_t uid = 0;
};

namespace {

constexpr std::uint32_t kNoOwner = 0xFFFFFFFFu;

struct UdpOwner {
  std::uint32_t uid = 0xFFFFFFFFu;  ///< kNoOwner: no socket of this host.
  std::uint64_t inode = 0;
};

// The owner (uid) and inode of this host's UDP socket bound to `source` (address or 0.0.0.0, and port), from
// /proc/net/udp; uid kNoOwner when there is none (the datagram came from another machine, or the socket is gone).
// A socket bound to the exact address wins over a wildcard one. Set-up path (a hello) and the periodic re-check.
UdpOwner LocalOwner(const sockaddr_in& source) noexcept try {
  std::ifstream in("/proc/net/udp");
  std::string line;
  std::getline(in, line);  // header
  const unsigned port = ntohs(source.sin_port);
  UdpOwner found{};
  while (std::getline(in, line)) {
    unsigned sl = 0;
    unsigned local_address = 0;
    unsigned local_port = 0;
    unsigned remote_address = 0;
    unsigned remote_port = 0;
    unsigned state = 0;
    unsigned long tx = 0;
    unsigned long rx = 0;
    unsigned tr = 0;
    unsigned long when = 0;
    unsigned long retransmits = 0;
    unsigned uid = 0;
    unsigned long timeout = 0;
    unsigned long inode = 0;
    if (std::sscanf(line.c_str(), " %u: %X:%X %X:%X %X %lX:%lX %X:%lX %lX %u %lu %lu", &sl, &local_address, &local_port,
                    &remote_address, &remote_port, &state, &tx, &rx, &tr, &when, &retransmits, &uid, &timeout,
                    &inode) != 14) {
      continue;
    }
    // The kernel prints the address as the raw (network-order) 32-bit value: compare with s_addr as stored.
    if (local_port != port) continue;
    if (local_address == source.sin_addr.s_addr) return UdpOwner{uid, inode};
    if (local_address == 0) found = UdpOwner{uid, inode};
  }
  return found;
} catch (...) {
  return UdpOwner{};  // cannot read it: treated as not a local socket (refused unless remote nodes are allowed)
}

bool Contains(const std::vector<std::uint32_t>& list, std::uint32_t uid, std::uint32_t own) {
  return list.empty() ? uid == own : std::find(list.begin(), list.end(), uid) != list.end();
}

bool SameAddress(const sockaddr_storage& a, socklen_t a_len, const sockaddr_storage& b, socklen_t b_len) noexcept {
  if (a.ss_family != b.ss_family) return false;
  if (a.ss_family == AF_INET) {
    sockaddr_in x{};
    sockaddr_in y{};
    std::memcpy(&x, &a, sizeof x);
    std::memcpy(&y, &b, sizeof y);
    return x.sin_addr.s_addr == y.sin_addr.s_addr && x.sin_port == y.sin_port;
  }
  return a_len == b_len && std::memcmp(&a, &b, a_len) == 0;  // AF_UNIX: the same (abstract) name
}

constexpr std::string_view kUnixPrefix = "unix:";

// The connecting process's credentials, recorded by the kernel at connect() (SO_PEERCRED): kNoOwner if unreadable.
std::uint32_t PeerUid(int fd) noexcept {
  ucred credentials{};
  socklen_t len = sizeof credentials;
  if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &credentials, &len) != 0 || len != sizeof credentials) return kNoOwner;
  return credentials.uid;
}

constexpr std::size_t kMaxConnections = 64;  // connections before (or without) a hello; more are closed at once

/// The error frame a node gets back for a frame the bus refused, as its controller would report it: bus-off, or a
/// transmit overflow (the UDP and the Unix-socket paths send the same).
bus_datagram::Message RefusalFrame(CanWriteStatus status) noexcept {
  bus_datagram::Message e{};
  e.type = bus_datagram::Type::kFrame;
  e.frame.error = true;
  e.frame.len = 8;
  if (status == CanWriteStatus::kBusOff) {
    e.frame.error_class = proto::can::kErrBusOff;
  } else {
    e.frame.error_class = proto::can::kErrController;
    e.frame.data[1] = proto::can::kCtrlTxOverflow;
  }
  return e;
}

}  // namespace

CanBusServer::CanBusServer(const CanBusServerConfig& config) : config_(config), bus_(config.bus) {
  if (config.max_nodes < 1 || config.max_nodes > 64) throw Error("teleop-canbus: max_nodes must be 1..64");
  nodes_.reserve(static_cast<std::size_t>(config.max_nodes));
  if (config.bind_address.rfind(kUnixPrefix, 0) == 0) {
    unix_path_ = config.bind_address.substr(kUnixPrefix.size());
    BindUnix();
  } else {
    BindUdp();
  }
  started_ns_ = EmulatedCanBus::SteadyNow_ns();
  if (!config.candump_log_path.empty()) {
    try {
      log_ = std::make_unique<CandumpLogWriter>(config.candump_log_path, config.candump_interface);
    } catch (...) {
      Close();
      throw;
    }
    monitor_node_ = bus_.AddNode();  // hears every frame, like candump on an interface
  }
}

void CanBusServer::BindUdp() {
  const CanBusServerConfig& config = config_;
  socket_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (socket_ < 0) throw Error(std::string("teleop-canbus: socket: ") + std::strerror(errno));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(config.port);
  if (::inet_pton(AF_INET, config.bind_address.c_str(), &addr.sin_addr) != 1) {
    ::close(socket_);
    throw Error("teleop-canbus: bind address '" + config.bind_address + "' is not an IPv4 address");
  }
  if (::bind(socket_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) < 0) {  // NOLINT: sockets API
    const std::string reason = std::strerror(errno);
    ::close(socket_);
    throw Error(fmt::format("teleop-canbus: cannot bind {}:{}: {} (another teleop-canbus running? use --port)",
                            config.bind_address, config.port, reason));
  }
  allow_remote_ =
      config.allow_remote == CanBusServerConfig::Remote::kAllow ||
      (config.allow_remote == CanBusServerConfig::Remote::kByBindAddress && (ntohl(addr.sin_addr.s_addr) >> 24) != 127);
  socklen_t len = sizeof(addr);
  ::getsockname(socket_, reinterpret_cast<sockaddr*>(&addr), &len);  // NOLINT: sockets API
  port_ = ntohs(addr.sin_port);
}

void CanBusServer::BindUnix() {
  const std::string& path = unix_path_;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof(addr.sun_path)) {
    throw Error(
        fmt::format("teleop-canbus: socket path '{}' must be 1..{} characters", path, sizeof(addr.sun_path) - 1));
  }
  std::memcpy(addr.sun_path, path.data(), path.size());
  const auto len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + path.size() + 1);
  const auto* any = reinterpret_cast<const sockaddr*>(&addr);  // NOLINT: sockets API
  // A file already at the path: a socket no process has bound is stale (a daemon that was killed) and is replaced;
  // one a daemon has bound answers connect(), and so does nothing else: refuse (never take over a live bus); not a
  // socket at all: refuse (never delete an operator's file).
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) {
      throw Error(
          fmt::format("teleop-canbus: {} exists and is not a socket: not replaced (remove it or choose "
                      "another path)",
                      path));
    }
    const int probe = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
    if (probe < 0) throw Error(std::string("teleop-canbus: socket: ") + std::strerror(errno));
    const int rc = ::connect(probe, any, len);
    const int probe_errno = errno;
    ::close(probe);
    if (rc == 0) {
      throw Error(
          fmt::format("teleop-canbus: another teleop-canbus is running on {} (it answered): stop it or "
                      "choose another path",
                      path));
    }
    if (probe_errno != ECONNREFUSED) {
      throw Error(fmt::format("teleop-canbus: cannot tell whether {} is in use: {}", path, std::strerror(probe_errno)));
    }
    if (::unlink(path.c_str()) != 0) {
      throw Error(fmt::format("teleop-canbus: cannot remove the stale socket {}: {}", path, std::strerror(errno)));
    }
    stale_replaced_ = true;
  }
  socket_ = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (socket_ < 0) throw Error(std::string("teleop-canbus: socket: ") + std::strerror(errno));
  // Created owner-only, then given its group and mode: no moment where the file is wider than configured.
  const mode_t old_umask = ::umask(0177);
  const int bound = ::bind(socket_, any, len);
  const int bind_errno = errno;
  ::umask(old_umask);
  const auto fail = [&](const std::string& what, int error) {
    ::close(socket_);
    socket_ = -1;
    throw Error(fmt::format("teleop-canbus: {} {}: {}", what, path, std::strerror(error)));
  };
  if (bound != 0) fail("cannot bind", bind_errno);
  if (::listen(socket_, 16) != 0) {
    const int e = errno;
    ::unlink(path.c_str());
    fail("cannot listen on", e);
  }
  conns_.reserve(kMaxConnections);
  if (config_.socket_gid >= 0 &&
      ::chown(path.c_str(), static_cast<uid_t>(-1), static_cast<gid_t>(config_.socket_gid)) != 0) {
    const int e = errno;
    ::unlink(path.c_str());
    fail(fmt::format("cannot give group {} to", config_.socket_gid), e);
  }
  if (::chmod(path.c_str(), static_cast<mode_t>(config_.socket_mode & 07777u)) != 0) {
    const int e = errno;
    ::unlink(path.c_str());
    fail("cannot chmod", e);
  }
  if (::stat(path.c_str(), &st) == 0) unix_inode_ = st.st_ino;
  allow_remote_ = false;  // a Unix socket has no remote nodes
}

void CanBusServer::Close() noexcept {
  for (const Conn& c : conns_) ::close(c.fd);
  conns_.clear();
  if (socket_ >= 0) ::close(socket_);
  socket_ = -1;
  if (!unix_path_.empty() && unix_inode_ != 0) {
    struct stat st {};
    // Only the file this daemon created: a later daemon's socket at the same path is left alone.
    if (::lstat(unix_path_.c_str(), &st) == 0 && S_ISSOCK(st.st_mode) && st.st_ino == unix_inode_) {
      ::unlink(unix_path_.c_str());
    }
    unix_inode_ = 0;
  }
}

int CanBusServer::node_count() const noexcept { return static_cast<int>(nodes_.size()); }

CanBusServer::~CanBusServer() { Close(); }

void CanBusServer::Step(std::uint64_t max_wait_ns) noexcept {
  const std::uint64_t now = EmulatedCanBus::SteadyNow_ns();
  const std::uint64_t next = bus_.NextEvent_ns();
  std::uint64_t wait = max_wait_ns;
  if (next != UINT64_MAX) wait = next > now ? std::min(wait, next - now) : 0;
  const timespec timeout{static_cast<time_t>(wait / 1'000'000'000u), static_cast<long>(wait % 1'000'000'000u)};
  if (unix_path_.empty()) {
    ReceiveUdp(timeout);
  } else {
    ReceiveUnix(timeout);
  }
  Forward();
}

// UDP: every datagram names its sender by its source address only; drained without blocking, bounded so the bus
// keeps time.
void CanBusServer::ReceiveUdp(const timespec& timeout) noexcept {
  pollfd pfd{socket_, POLLIN, 0};
  ::ppoll(&pfd, 1, &timeout, nullptr);
  CheckUdpNodes(EmulatedCanBus::SteadyNow_ns());  // before the drain: what a dead node's successor sent is not its
  std::array<std::uint8_t, 256> buffer{};
  for (int i = 0; i < 1024; ++i) {
    sockaddr_storage source{};
    socklen_t source_len = sizeof(source);
    // The sockets API takes the address as sockaddr*; sockaddr_storage is the documented way to pass it.
    const ssize_t n =
        ::recvfrom(socket_, buffer.data(), buffer.size(), MSG_DONTWAIT,
                   reinterpret_cast<sockaddr*>(&source),  // NOLINT(cppcoreguidelines-pro-type-reinterpret-cast)
                   &source_len);
    if (n < 0) break;
    Dispatch(From{&source, source_len, -1, kNoOwner},
             std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)));
  }
}

// Unix mode (SOCK_SEQPACKET): one connection per node, its uid from SO_PEERCRED at accept; the socket file's
// permissions decided who could connect at all. Every connection is read without blocking, at most 256 messages
// each per step; a connection that closes detaches its node.
void CanBusServer::ReceiveUnix(const timespec& timeout) noexcept {
  std::array<pollfd, kMaxConnections + 1> fds{};
  fds[0] = pollfd{socket_, POLLIN, 0};
  for (std::size_t i = 0; i < conns_.size(); ++i) fds[i + 1] = pollfd{conns_[i].fd, POLLIN, 0};
  ::ppoll(fds.data(), conns_.size() + 1, &timeout, nullptr);
  for (;;) {  // accept what is pending
    const int fd = ::accept4(socket_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) break;
    if (conns_.size() == kMaxConnections) {
      ::close(fd);
      ++refused_hellos_;  // no room: as a refused hello, the node says no daemon answered
      continue;
    }
    conns_.push_back(Conn{fd, PeerUid(fd)});
  }
  std::array<std::uint8_t, 256> buffer{};
  for (std::size_t c = 0; c < conns_.size();) {
    const Conn conn = conns_[c];
    bool closed = false;
    for (int i = 0; i < 256; ++i) {
      const ssize_t n = ::recv(conn.fd, buffer.data(), buffer.size(), MSG_DONTWAIT);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
        closed = true;  // the node closed (or died): as a bye
        break;
      }
      if (n < 0) break;
      Dispatch(From{nullptr, 0, conn.fd, conn.uid},
               std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)));
    }
    if (closed) {
      const auto peer = std::find_if(nodes_.begin(), nodes_.end(), [&](const Peer& p) { return p.fd == conn.fd; });
      if (peer != nodes_.end()) nodes_.erase(peer);  // the bus node stays (idle)
      ::close(conn.fd);
      conns_.erase(conns_.begin() + static_cast<std::ptrdiff_t>(c));
      continue;
    }
    ++c;
  }
}

// One message from one sender, whatever carried it: the same rules for UDP and Unix nodes. Who may join is the
// sender's uid (Unix: the kernel's; UDP: the owner of the sending socket, or a remote node where the network is the
// bus); control commands only from an attached local node of a controller's user, its ownership re-checked first.
void CanBusServer::Dispatch(const From& from, std::span<const std::uint8_t> bytes) noexcept {
  bus_datagram::Message m{};
  if (!bus_datagram::Decode(bytes, m)) {
    ++malformed_;
    return;
  }
  const auto own_uid = static_cast<std::uint32_t>(::geteuid());
  auto peer = std::find_if(nodes_.begin(), nodes_.end(), [&](const Peer& p) {
    return from.fd >= 0 ? p.fd == from.fd
                        : p.fd < 0 && SameAddress(p.address, p.address_len, *from.address, from.address_len);
  });
  if (peer != nodes_.end()) peer->last_heard_ns = EmulatedCanBus::SteadyNow_ns();
  switch (m.type) {
    case bus_datagram::Type::kHello: {
      if (peer != nodes_.end() && !StillOwned(*peer)) {  // another socket on a dead node's address: not that node
        ++orphaned_nodes_;
        nodes_.erase(peer);
        peer = nodes_.end();
      }
      if (peer == nodes_.end()) {
        if (!Attach(from)) break;  // no welcome: the node times out and says no daemon answered
        peer = nodes_.end() - 1;
      }
      bus_datagram::Message w{};
      w.type = bus_datagram::Type::kWelcome;
      w.node = static_cast<std::uint8_t>(peer->node);
      SendTo(from, w);
      break;
    }
    case bus_datagram::Type::kFrame: {
      if (peer == nodes_.end()) {
        ++malformed_;
        break;
      }
      const CanWriteStatus status = bus_.Submit(peer->node, m.frame);
      if (status != CanWriteStatus::kOk) SendTo(from, RefusalFrame(status));  // as a controller error frame would
      break;
    }
    case bus_datagram::Type::kControl:
      // Only an attached node of a controller's user, still the socket that said hello: anyone else could take
      // the bus down.
      if (peer == nodes_.end() || !peer->local || !Contains(config_.controller_uids, peer->uid, own_uid) ||
          !StillOwned(*peer)) {
        ++refused_controls_;
        break;
      }
      if (m.action == bus_datagram::Action::kInjectErrors) bus_.InjectErrors(static_cast<int>(m.argument));
      if (m.action == bus_datagram::Action::kBusOff) bus_.ForceBusOff(static_cast<int>(m.argument));
      if (m.action == bus_datagram::Action::kRestart) bus_.Restart(static_cast<int>(m.argument));
      break;
    case bus_datagram::Type::kBye:
      if (peer != nodes_.end()) nodes_.erase(peer);  // the bus node stays (idle); a new hello gets a new one
      break;
    default:
      ++malformed_;
      break;
  }
}

// A new node for `from` when it may join: who it is (Unix: the kernel's uid; UDP: the owner and inode of the sending
// socket, or a remote node where the network is the bus) and whether that user is allowed. False (a refusal counted)
// when not, or when the bus is full.
bool CanBusServer::Attach(const From& from) noexcept {
  if (nodes_.size() == nodes_.capacity()) return false;  // full: the node times out and says so
  Peer p{};
  p.fd = from.fd;
  p.last_heard_ns = EmulatedCanBus::SteadyNow_ns();
  if (from.fd >= 0) {
    p.uid = from.uid;
    p.local = from.uid != kNoOwner;
  } else {
    p.address = *from.address;
    p.address_len = from.address_len;
    sockaddr_in udp_source{};
    std::memcpy(&udp_source, from.address, sizeof udp_source);
    const UdpOwner owner = LocalOwner(udp_source);
    p.uid = owner.uid;
    p.inode = owner.inode;
    p.local = owner.uid != kNoOwner;
  }
  const auto own_uid = static_cast<std::uint32_t>(::geteuid());
  const bool allowed = p.local ? Contains(config_.allowed_uids, p.uid, own_uid) : from.fd < 0 && allow_remote_;
  if (!allowed) {
    ++refused_hellos_;
    return false;
  }
  try {
    p.node = bus_.AddNode();  // a node that said bye keeps its (idle) bus node
  } catch (...) {
    return false;
  }
  nodes_.push_back(p);
  return true;
}

void CanBusServer::SendTo(const From& to, const bus_datagram::Message& m) noexcept {
  std::array<std::uint8_t, bus_datagram::kMaxSize> out{};
  const std::size_t size = bus_datagram::Encode(m, out);
  if (to.fd >= 0) {
    (void)::send(to.fd, out.data(), size, MSG_DONTWAIT | MSG_NOSIGNAL);
    return;
  }
  (void)::sendto(socket_, out.data(), size, MSG_DONTWAIT,
                 reinterpret_cast<const sockaddr*>(to.address),  // NOLINT: sockets API
                 to.address_len);
}

bool CanBusServer::StillOwned(const Peer& peer) const noexcept {
  if (peer.fd >= 0 || !peer.local) return true;  // a connection is its process's; a remote node has no owner here
  sockaddr_in address{};
  std::memcpy(&address, &peer.address, sizeof address);
  const UdpOwner now = LocalOwner(address);
  return now.uid == peer.uid && now.inode == peer.inode;
}

// UDP: a node is the socket that said hello. Every kOwnerCheckPeriod_ns the sockets of local nodes are looked up
// again and a node whose address another socket now holds (or none) is detached (`orphaned_nodes`); a node silent
// for node_timeout_ms is detached (`silent_nodes`). A detached node's bus node stays idle; a new hello attaches anew,
// with the admission check.
void CanBusServer::CheckUdpNodes(std::uint64_t now_ns) noexcept {
  const bool check_owners = now_ns - last_owner_check_ns_ >= kOwnerCheckPeriod_ns;
  if (check_owners) last_owner_check_ns_ = now_ns;
  const auto timeout_ns = static_cast<std::uint64_t>(config_.node_timeout_ms) * 1'000'000u;
  for (std::size_t i = nodes_.size(); i-- > 0;) {
    const Peer& p = nodes_[i];
    if (config_.node_timeout_ms > 0 && now_ns > p.last_heard_ns && now_ns - p.last_heard_ns > timeout_ns) {
      ++silent_nodes_;
      nodes_.erase(nodes_.begin() + static_cast<std::ptrdiff_t>(i));
    } else if (check_owners && !StillOwned(p)) {
      ++orphaned_nodes_;
      nodes_.erase(nodes_.begin() + static_cast<std::ptrdiff_t>(i));
    }
  }
}

void CanBusServer::Forward() noexcept {
  bus_.Run();
  bus_datagram::Message m{};
  m.type = bus_datagram::Type::kFrame;
  for (int node = 0; node < bus_.node_count(); ++node) {
    if (node == monitor_node_) {
      bool any = false;
      while (bus_.Receive(node, m.frame)) {
        timespec now{};
        ::clock_gettime(CLOCK_REALTIME, &now);
        (void)log_->Write(
            m.frame, static_cast<std::uint64_t>(now.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(now.tv_nsec));
        any = true;
      }
      if (any) {
        log_->Flush();
        logged_.store(log_->lines());
      }
      continue;
    }
    const auto peer = std::find_if(nodes_.begin(), nodes_.end(), [&](const Peer& p) { return p.node == node; });
    while (bus_.Receive(node, m.frame)) {
      if (peer == nodes_.end()) continue;  // detached node: drain and drop
      SendTo(From{&peer->address, peer->address_len, peer->fd, peer->uid}, m);
    }
  }
}

void CanBusServer::Run(const std::atomic<bool>& stop) noexcept {
  while (!stop.load(std::memory_order_relaxed)) Step(20'000'000);  // 20 ms: notice `stop` promptly
}

std::string CanBusServer::Describe() const {
  const double elapsed_s = static_cast<double>(EmulatedCanBus::SteadyNow_ns() - started_ns_) * 1e-9;
  const EmulatedCanBus::Stats& s = bus_.stats();
  return fmt::format(
      "teleop-canbus {}:{}: {} node(s), {} frames, {} error frames, {} refused, {} rx overflows, {} malformed "
      "datagrams, {} hellos and {} control commands refused (not allowed), {} nodes detached as silent and {} as "
      "orphaned (another socket on their address), mean bus load {:.1f} % over {:.1f} s",
      unix_path_.empty() ? config_.bind_address : "unix", unix_path_.empty() ? std::to_string(port_) : unix_path_,
      nodes_.size(), s.frames_delivered, s.error_frames, s.tx_refused, s.rx_overflows, malformed_.load(),
      refused_hellos_.load(), refused_controls_.load(), silent_nodes_.load(), orphaned_nodes_.load(),
      elapsed_s > 0 ? 100.0 * static_cast<double>(s.busy_ns) * 1e-9 / elapsed_s : 0.0, elapsed_s);
}

}  // namespace teleop::transport
