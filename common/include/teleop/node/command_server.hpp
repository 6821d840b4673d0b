#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "teleop/node/teleop_node.hpp"

namespace teleop::node {

/// The local command channel (docs/clutch.md, "Run-time commands"): a Unix stream socket served by its own thread,
/// one command line per connection, one reply line. Who may command: the socket file's permissions (created with
/// `mode`, owned by this process's user) and SO_PEERCRED (the peer's uid must be this process's effective uid, or
/// root). The stability check of a stiffness or gain change runs on this thread, never the cycle's.
///
/// Clients are served side by side (up to kMaxClients connections at once, without blocking on any of them), each
/// with a deadline for its whole request (kRequestDeadline_ms from accept to the newline): a slow or silent client
/// never delays another's `clutch on` (docs/security.md, "The command socket").
///
/// Commands: `clutch on|off`, `fixture on|off [ramp_s]`, `fixture-stiffness <N/m> [ramp_s]`, `fixture-plane
/// <offset_m> <normal: dof numbers> [rate_m_per_s]`, `gain <name>[:<axis>] <value> [ramp_s]` (names as in the
/// config's law section). Replies start with `ok`, `refused` or `error`. Every command and its outcome is an event
/// (a malformed command and a refused peer too: TeleopNode::RecordCommandEvent).
class CommandServer {
 public:
  struct Config {
    /// The socket's file path. A file already there is replaced only when it is a stale socket of this process's
    /// user (nothing answers it); anything else (another user's file, a live socket, not a socket) is refused.
    std::string path;
    unsigned mode = 0600;         ///< The socket file's permissions.
    double default_ramp_s = 0.5;  ///< The ramp of a change that names none.
  };

  static constexpr std::size_t kMaxClients = 8;     ///< Connections served at once; more are refused ("busy").
  static constexpr int kRequestDeadline_ms = 1000;  ///< From accept to the end of the command line.
  static constexpr std::size_t kMaxLine = 256;      ///< Bytes of a command line; more are cut.

  /// Binds the socket and starts its thread. Throws teleop::Error naming the path (and the owner of a file that
  /// is in the way) when it cannot.
  CommandServer(TeleopNode& node, const Config& config);
  ~CommandServer();
  CommandServer(const CommandServer&) = delete;
  CommandServer& operator=(const CommandServer&) = delete;

  /// One command line → its reply (what a connection gets; public for tests and for a caller without a socket).
  std::string Execute(const std::string& line);

  std::uint64_t commands() const noexcept { return commands_.load(); }
  std::uint64_t refused_peers() const noexcept { return refused_peers_.load(); }  ///< SO_PEERCRED refusals.
  std::uint64_t malformed() const noexcept { return malformed_.load(); }
  /// Connections closed without a command: no complete line within kRequestDeadline_ms.
  std::uint64_t timed_out() const noexcept { return timed_out_.load(); }
  /// Connections refused because kMaxClients were being served.
  std::uint64_t busy() const noexcept { return busy_.load(); }

 private:
  struct Client;
  void Serve() noexcept;
  void Accept(std::vector<Client>& clients) noexcept;
  /// Reads what `client` sent; true when its request is complete (a newline, kMaxLine bytes or end of stream).
  bool Read(Client& client) noexcept;
  void Reply(int fd, const std::string& text) noexcept;

  TeleopNode& node_;
  Config config_;
  int listen_fd_ = -1;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> commands_{0};
  std::atomic<std::uint64_t> refused_peers_{0};
  std::atomic<std::uint64_t> malformed_{0};
  std::atomic<std::uint64_t> timed_out_{0};
  std::atomic<std::uint64_t> busy_{0};
  std::uint64_t inode_ = 0;  ///< The socket file this server made: removed at the end only while it is still it.
  std::thread thread_;
};

}  // namespace teleop::node
