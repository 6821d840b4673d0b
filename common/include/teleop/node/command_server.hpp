#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <thread>

#include "teleop/node/teleop_node.hpp"

namespace teleop::node {

/// The local command channel (docs/clutch.md, "Run-time commands"): a Unix stream socket served by its own thread,
/// one command line per connection, one reply line. Who may command: the socket file's permissions (created with
/// `mode`, owned by this process's user) and SO_PEERCRED (the peer's uid must be this process's effective uid, or
/// root). The stability check of a stiffness or gain change runs on this thread, never the cycle's.
///
/// Commands: `clutch on|off`, `fixture on|off [ramp_s]`, `fixture-stiffness <N/m> [ramp_s]`, `fixture-plane
/// <offset_m> <normal: dof numbers> [rate_m_per_s]`, `gain <name>[:<axis>] <value> [ramp_s]` (names as in the
/// config's law section). Replies start with `ok`, `refused` or `error`. Every command and its outcome is an event
/// (a malformed command and a refused peer too: TeleopNode::RecordCommandEvent).
class CommandServer {
 public:
  struct Config {
    std::string path;             ///< The socket's file path (an existing socket file there is replaced).
    unsigned mode = 0600;         ///< The socket file's permissions.
    double default_ramp_s = 0.5;  ///< The ramp of a change that names none.
  };

  /// Binds the socket and starts its thread. Throws teleop::Error naming the path when it cannot.
  CommandServer(TeleopNode& node, const Config& config);
  ~CommandServer();
  CommandServer(const CommandServer&) = delete;
  CommandServer& operator=(const CommandServer&) = delete;

  /// One command line → its reply (what a connection gets; public for tests and for a caller without a socket).
  std::string Execute(const std::string& line);

  std::uint64_t commands() const noexcept { return commands_.load(); }
  std::uint64_t refused_peers() const noexcept { return refused_peers_.load(); }  ///< SO_PEERCRED refusals.
  std::uint64_t malformed() const noexcept { return malformed_.load(); }

 private:
  void Serve() noexcept;
  void Handle(int fd) noexcept;

  TeleopNode& node_;
  Config config_;
  int listen_fd_ = -1;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> commands_{0};
  std::atomic<std::uint64_t> refused_peers_{0};
  std::atomic<std::uint64_t> malformed_{0};
  std::thread thread_;
};

}  // namespace teleop::node
