#pragma once

#include <atomic>
#include <cstdint>
#include <ctime>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "teleop/transport/can_bus_datagram.hpp"
#include "teleop/transport/can_emulated_bus.hpp"
#include "teleop/transport/can_log.hpp"

namespace teleop::transport {

struct CanBusServerConfig {
  /// An IPv4 address (UDP on `port`), or `unix:PATH`: a Unix-domain SOCK_SEQPACKET socket at PATH (docs/security.md,
  /// "What CAN trusts"), created with `socket_mode` and `socket_gid`; the peer's uid comes from the kernel
  /// (SO_PEERCRED of its connection), and a stale socket file is replaced, a live daemon's refused.
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 47300;   ///< 0: any free port (tests). Not used with `unix:`.
  unsigned socket_mode = 0600;  ///< `unix:` only: the socket file's permission bits (who may connect).
  int socket_gid = -1;          ///< `unix:` only: the socket file's group (-1: the daemon's).
  EmulatedCanBusConfig bus{};
  int max_nodes = 8;
  /// When set: every frame the bus carries (and every error frame) is appended to this file in candump -L format,
  /// stamped with the wall clock, as interface `candump_interface` (canplayer/log2asc read it).
  std::string candump_log_path;
  std::string candump_interface = "emcan0";
  /// Who may attach (docs/security.md, "What CAN trusts"). In UDP mode a datagram from a socket of this host is
  /// traced to its owner through /proc/net/udp; in `unix:` mode the kernel names the sender (SO_PEERCRED) and
  /// the socket file's mode and group decide who may send at all. A hello is answered only when that uid is in
  /// allowed_uids (empty: the daemon's own effective user only). A source that is no socket of this host (another
  /// machine) is admitted only with allow_remote, which defaults to on when the daemon binds a non-loopback address
  /// (the network is the bus).
  std::vector<std::uint32_t> allowed_uids;
  /// Who may send control commands (bus-off, restart, error injection): attached nodes whose owner is in this list
  /// (empty: the daemon's own effective user only). Remote nodes never may.
  std::vector<std::uint32_t> controller_uids;
  enum class Remote : std::uint8_t { kByBindAddress, kAllow, kRefuse };
  Remote allow_remote = Remote::kByBindAddress;
  /// UDP: a node from which nothing (frame, hello, control) arrived for this long is detached (0: never). Nodes
  /// send a hello at least every UdpCanBusPort::kKeepAlive_ms when they send nothing else.
  int node_timeout_ms = 2000;
};

/// The core of teleop-canbus: an EmulatedCanBus on the wall clock, shared by nodes that talk to it over UDP
/// (bus_datagram). A frame a node sends is queued on the bus and forwarded to every other node when its
/// transmission ends (ID-order arbitration, frame time at the configured bit rates); error frames go the same way.
/// Single-threaded: Step() waits for a datagram or the next bus event, whichever comes first.
class CanBusServer {
 public:
  explicit CanBusServer(const CanBusServerConfig& config);  ///< Binds; throws teleop::Error.
  ~CanBusServer();
  CanBusServer(const CanBusServer&) = delete;
  CanBusServer& operator=(const CanBusServer&) = delete;

  /// One iteration: wait up to `max_wait_ns` (less when the bus has an event due), handle datagrams, deliver.
  void Step(std::uint64_t max_wait_ns) noexcept;
  /// Steps until `stop` is true.
  void Run(const std::atomic<bool>& stop) noexcept;

  std::uint16_t port() const noexcept { return port_; }
  /// The Unix socket's path (empty in UDP mode).
  const std::string& unix_path() const noexcept { return unix_path_; }
  /// True when start-up found a stale socket file (no daemon bound to it) at the path and replaced it.
  bool replaced_stale_socket() const noexcept { return stale_replaced_; }
  const EmulatedCanBus& bus() const noexcept { return bus_; }
  int node_count() const noexcept;
  std::uint64_t malformed_datagrams() const noexcept { return malformed_.load(); }
  /// Hellos refused (owner not allowed, or a remote source without allow_remote) and control commands refused (not
  /// from a controller). Read from other threads (tests).
  std::uint64_t refused_hellos() const noexcept { return refused_hellos_.load(); }
  std::uint64_t refused_controls() const noexcept { return refused_controls_.load(); }
  /// UDP: nodes detached because nothing came from them for node_timeout_ms, and because the socket that said
  /// hello no longer holds their address (its process died; another socket may have bound the freed port). Read
  /// from other threads (tests).
  std::uint64_t silent_nodes() const noexcept { return silent_nodes_.load(); }
  std::uint64_t orphaned_nodes() const noexcept { return orphaned_nodes_.load(); }
  /// UDP: how often the sockets of attached local nodes are looked up again (and before every control command).
  static constexpr std::uint64_t kOwnerCheckPeriod_ns = 10'000'000;
  /// Lines written to the candump log so far (0 without one). Read from other threads (tests).
  std::uint64_t logged_frames() const noexcept { return logged_.load(); }
  std::string Describe() const;

 private:
  struct Peer;
  struct Conn {
    int fd = -1;
    std::uint32_t uid = 0;  ///< SO_PEERCRED at accept.
  };
  struct From;
  void ReceiveUdp(const timespec& timeout) noexcept;
  void ReceiveUnix(const timespec& timeout) noexcept;
  void Dispatch(const From& from, std::span<const std::uint8_t> bytes) noexcept;
  bool Attach(const From& from) noexcept;
  void SendTo(const From& to, const bus_datagram::Message& m) noexcept;
  bool StillOwned(const Peer& peer) const noexcept;
  void CheckUdpNodes(std::uint64_t now_ns) noexcept;
  void BindUdp();
  void BindUnix();
  void Close() noexcept;
  void Forward() noexcept;

  CanBusServerConfig config_;
  EmulatedCanBus bus_;
  int socket_ = -1;
  std::uint16_t port_ = 0;
  std::string unix_path_;         ///< Non-empty: Unix-domain mode, the socket file (removed by the destructor).
  std::uint64_t unix_inode_ = 0;  ///< The socket file's inode: removed only while it is still ours.
  bool stale_replaced_ = false;
  std::vector<Peer> nodes_;
  std::vector<Conn> conns_;  ///< Unix mode: accepted connections (attached or not yet).
  std::atomic<std::uint64_t> malformed_{0};
  std::atomic<std::uint64_t> refused_hellos_{0};
  std::atomic<std::uint64_t> refused_controls_{0};
  std::atomic<std::uint64_t> silent_nodes_{0};
  std::atomic<std::uint64_t> orphaned_nodes_{0};
  std::uint64_t last_owner_check_ns_ = 0;
  bool allow_remote_ = false;
  std::atomic<std::uint64_t> logged_{0};  ///< Read from other threads (tests).
  std::uint64_t started_ns_ = 0;
  int monitor_node_ = -1;  ///< The bus node that feeds the candump log (-1: none).
  std::unique_ptr<CandumpLogWriter> log_;
};

}  // namespace teleop::transport
