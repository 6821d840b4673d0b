#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "teleop/dds/process_view.hpp"
#include "teleop/dds/state_trace.hpp"

namespace teleop::dds {

/// Where libjs-dygraphs installs dygraph.min.js and dygraph.min.css (`dpkg -L libjs-dygraphs`).
inline constexpr std::string_view kDefaultDygraphsDir = "/usr/share/javascript/dygraphs";

/// An address and port to listen on.
struct HttpEndpoint {
  std::string address;
  std::uint16_t port = 0;
};

/// `--http` of teleop-supervise: "PORT" (on 127.0.0.1), "ADDRESS:PORT" or "[IPV6]:PORT"; the address must be a
/// numeric IPv4 or IPv6 address (0.0.0.0 to listen on every interface, which the operator must ask for). Throws
/// teleop::Error naming what is wrong.
HttpEndpoint ParseHttpEndpoint(std::string_view text);

/// teleop-supervise's live dashboard (docs/dds.md, "The dashboard"): an HTTP server for the page (embedded at build
/// time) and dygraphs (served from its installed directory), and a WebSocket (/ws) that streams the process table and,
/// for the pair a page subscribed to, every State sample's traces and every event.
///
/// Threads: the server runs on its own thread (Boost.Asio/Beast). The Publish* calls come from the supervisor's
/// thread (the DDS reader); each one takes a mutex only to append to a bounded queue (no I/O, no encoding under it):
/// a full queue drops the sample and counts it. Every 50 ms the server thread encodes what is queued once and hands
/// it to each client. Memory per client is bounded: a client whose unsent messages exceed `client_queue_bytes` (a
/// slow reader, or one whose TCP window closed) is dropped, as is one that answers no ping for `idle_timeout_s`;
/// a page's messages are at most 256 bytes; HTTP headers at most 8 KiB.
class DashboardServer {
 public:
  struct Config {
    HttpEndpoint endpoint{"127.0.0.1", 8080};
    std::string dygraphs_dir{kDefaultDygraphsDir};
    std::size_t max_connections = 32;            ///< HTTP and WebSocket connections at once; more are closed.
    std::size_t client_queue_bytes = 1U << 20U;  ///< Unsent bytes per WebSocket client before it is dropped.
    std::size_t max_pending = 8192;              ///< States and events queued between two server ticks.
    double idle_timeout_s = 10.0;                ///< A WebSocket client silent (no pong) this long is dropped.
  };
  struct Stats {
    std::uint64_t connections_accepted = 0;
    std::uint64_t connections_refused = 0;   ///< Over max_connections.
    std::uint64_t websocket_clients = 0;     ///< Open now.
    std::uint64_t clients_dropped_slow = 0;  ///< Unsent bytes over client_queue_bytes.
    std::uint64_t websocket_refused = 0;     ///< Upgrade with a foreign Origin, or not on /ws.
    std::uint64_t requests_malformed = 0;    ///< Bad HTTP, or a page message that is not a request.
    std::uint64_t samples_dropped = 0;       ///< Publish* calls that found the queue full.
    std::uint64_t messages_sent = 0;         ///< WebSocket messages written, all clients.
  };

  /// Listens on config.endpoint and starts the server thread. Throws teleop::Error when it cannot listen.
  explicit DashboardServer(Config config);
  /// Stops the thread and closes every connection.
  ~DashboardServer();
  DashboardServer(const DashboardServer&) = delete;
  DashboardServer& operator=(const DashboardServer&) = delete;

  /// The port listened on (the kernel's choice when config.endpoint.port was 0).
  std::uint16_t port() const noexcept;
  /// True when dygraph.min.js was found in config.dygraphs_dir (the page shows the table only without it).
  bool have_dygraphs() const noexcept;

  /// A State sample's traces; `t_s` on the supervisor's clock. Never blocks on a client.
  void PublishState(const StateTrace& trace, double t_s);
  /// An event of one process. Never blocks on a client.
  void PublishEvent(const std::string& pair, const std::string& role, const std::string& kind_name, std::uint64_t cycle,
                    double value, double t_s);
  /// The table of every process (the newest replaces one not yet sent). Never blocks on a client.
  void PublishProcesses(std::vector<ProcessView> views, double t_s);

  Stats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace teleop::dds
