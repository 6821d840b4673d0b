#include "teleop/transport/can_bus_server.hpp"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>

#include "teleop/error.hpp"
#include "teleop/transport/can_bus_datagram.hpp"

namespace teleop::transport {

struct CanBusServer::Peer {
  sockaddr_in address{};
  int node = 0;
  bool local = false;  ///< A socket of this host (its owner is `uid`), not a remote node.
  std::uint32_t uid = 0;
};

namespace {

constexpr std::uint32_t kNoOwner = 0xFFFFFFFFu;

// The owner (uid) of this host's UDP socket bound to `source` (address or 0.0.0.0, and port), from /proc/net/udp;
// kNoOwner when there is none (the datagram came from another machine). Set-up path (a hello), not per frame.
std::uint32_t LocalOwner(const sockaddr_in& source) noexcept try {
  std::ifstream in("/proc/net/udp");
  std::string line;
  std::getline(in, line);  // header
  const unsigned port = ntohs(source.sin_port);
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
    if (std::sscanf(line.c_str(), " %u: %X:%X %X:%X %X %lX:%lX %X:%lX %lX %u", &sl, &local_address, &local_port,
                    &remote_address, &remote_port, &state, &tx, &rx, &tr, &when, &retransmits, &uid) != 12) {
      continue;
    }
    // The kernel prints the address as the raw (network-order) 32-bit value: compare with s_addr as stored.
    if (local_port == port && (local_address == source.sin_addr.s_addr || local_address == 0)) return uid;
  }
  return kNoOwner;
} catch (...) {
  return kNoOwner;  // cannot read it: treated as not a local socket (refused unless remote nodes are allowed)
}

bool Contains(const std::vector<std::uint32_t>& list, std::uint32_t uid, std::uint32_t own) {
  return list.empty() ? uid == own : std::find(list.begin(), list.end(), uid) != list.end();
}

bool SameAddress(const sockaddr_in& a, const sockaddr_in& b) noexcept {
  return a.sin_addr.s_addr == b.sin_addr.s_addr && a.sin_port == b.sin_port;
}

}  // namespace

CanBusServer::CanBusServer(const CanBusServerConfig& config) : config_(config), bus_(config.bus) {
  if (config.max_nodes < 1 || config.max_nodes > 64) throw Error("teleop-canbus: max_nodes must be 1..64");
  nodes_.reserve(static_cast<std::size_t>(config.max_nodes));
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
  started_ns_ = EmulatedCanBus::SteadyNow_ns();
  if (!config.candump_log_path.empty()) {
    try {
      log_ = std::make_unique<CandumpLogWriter>(config.candump_log_path, config.candump_interface);
    } catch (...) {
      ::close(socket_);
      throw;
    }
    monitor_node_ = bus_.AddNode();  // hears every frame, like candump on an interface
  }
}

int CanBusServer::node_count() const noexcept { return static_cast<int>(nodes_.size()); }

CanBusServer::~CanBusServer() {
  if (socket_ >= 0) ::close(socket_);
}

void CanBusServer::Step(std::uint64_t max_wait_ns) noexcept {
  const std::uint64_t now = EmulatedCanBus::SteadyNow_ns();
  const std::uint64_t next = bus_.NextEvent_ns();
  std::uint64_t wait = max_wait_ns;
  if (next != UINT64_MAX) wait = next > now ? std::min(wait, next - now) : 0;
  pollfd pfd{socket_, POLLIN, 0};
  const timespec timeout{static_cast<time_t>(wait / 1'000'000'000u), static_cast<long>(wait % 1'000'000'000u)};
  ::ppoll(&pfd, 1, &timeout, nullptr);
  std::array<std::uint8_t, 256> buffer{};
  for (int i = 0; i < 1024; ++i) {
    sockaddr_in source{};
    socklen_t source_len = sizeof(source);
    // The sockets API takes the address as sockaddr*; sockaddr_in is the documented way to pass it.
    const ssize_t n =
        ::recvfrom(socket_, buffer.data(), buffer.size(), 0,
                   reinterpret_cast<sockaddr*>(&source),  // NOLINT(cppcoreguidelines-pro-type-reinterpret-cast)
                   &source_len);
    if (n < 0) break;
    bus_datagram::Message m{};
    if (!bus_datagram::Decode(std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)), m)) {
      ++malformed_;
      continue;
    }
    auto peer =
        std::find_if(nodes_.begin(), nodes_.end(), [&](const Peer& p) { return SameAddress(p.address, source); });
    std::array<std::uint8_t, bus_datagram::kMaxSize> reply{};
    switch (m.type) {
      case bus_datagram::Type::kHello: {
        if (peer == nodes_.end()) {
          if (nodes_.size() == nodes_.capacity()) break;  // full: the node times out and says so
          // Who may join: the owner of the sending socket, or a remote node where the network is the bus.
          const std::uint32_t owner = LocalOwner(source);
          const bool local = owner != kNoOwner;
          if (local ? !Contains(config_.allowed_uids, owner, static_cast<std::uint32_t>(::geteuid()))
                    : !allow_remote_) {
            ++refused_hellos_;  // no welcome: the node times out and says no daemon answered
            break;
          }
          int node = 0;
          try {
            node = bus_.AddNode();  // a node that said bye keeps its (idle) bus node
          } catch (...) {
            break;
          }
          nodes_.push_back(Peer{source, node, local, owner});
          peer = nodes_.end() - 1;
        }
        bus_datagram::Message w{};
        w.type = bus_datagram::Type::kWelcome;
        w.node = static_cast<std::uint8_t>(peer->node);
        const std::size_t size = bus_datagram::Encode(w, reply);
        ::sendto(socket_, reply.data(), size, 0, reinterpret_cast<const sockaddr*>(&source), sizeof(source));  // NOLINT
        break;
      }
      case bus_datagram::Type::kFrame: {
        if (peer == nodes_.end()) {
          ++malformed_;
          break;
        }
        const CanWriteStatus status = bus_.Submit(peer->node, m.frame);
        if (status == CanWriteStatus::kOk) break;
        // Tell the node its frame was refused, as a controller error frame would.
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
        const std::size_t size = bus_datagram::Encode(e, reply);
        ::sendto(socket_, reply.data(), size, 0, reinterpret_cast<const sockaddr*>(&source), sizeof(source));  // NOLINT
        break;
      }
      case bus_datagram::Type::kControl:
        // Only an attached node of a controller's user: anyone else could take the bus down.
        if (peer == nodes_.end() || !peer->local ||
            !Contains(config_.controller_uids, peer->uid, static_cast<std::uint32_t>(::geteuid()))) {
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
  Forward();
}

void CanBusServer::Forward() noexcept {
  bus_.Run();
  std::array<std::uint8_t, bus_datagram::kMaxSize> out{};
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
      const std::size_t size = bus_datagram::Encode(m, out);
      ::sendto(socket_, out.data(), size, 0, reinterpret_cast<const sockaddr*>(&peer->address),  // NOLINT
               sizeof(peer->address));
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
      "datagrams, {} hellos and {} control commands refused (not allowed), mean bus load {:.1f} % over {:.1f} s",
      config_.bind_address, port_, nodes_.size(), s.frames_delivered, s.error_frames, s.tx_refused, s.rx_overflows,
      malformed_.load(), refused_hellos_.load(), refused_controls_.load(),
      elapsed_s > 0 ? 100.0 * static_cast<double>(s.busy_ns) * 1e-9 / elapsed_s : 0.0, elapsed_s);
}

}  // namespace teleop::transport
