#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
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

/// True when an HTTP Host header names a server bound to `bound_address`:`bound_port`: the port must be the bound
/// one (absent only for port 80), the name `localhost`, one of `allowed_hosts`, a loopback address, the bound address,
/// or any numeric address when bound to every interface (0.0.0.0, ::). Any other name is refused: a name that
/// another site's DNS now resolves to this machine (DNS rebinding) must not reach the dashboard.
bool HostHeaderAllowed(std::string_view host, const std::string& bound_address, std::uint16_t bound_port,
                       const std::vector<std::string>& allowed_hosts);

/// teleop-supervise's live dashboard (docs/dds.md, "The dashboard"): an HTTP server for the page (embedded at build
/// time) and dygraphs (served from its installed directory), and a WebSocket (/ws) that streams the process table and,
/// for the pair a page subscribed to, every State sample's traces and every event -- first the pair's history, its
/// last `history_s` seconds of them, so that a page opened mid-run shows them at once.
///
/// Threads: the server runs on its own thread (Boost.Asio/Beast). The Publish* calls come from the supervisor's
/// thread (the DDS reader); each one takes a mutex only to append to a bounded queue (no I/O, no encoding under it):
/// a full queue drops the sample and counts it. Every 50 ms the server thread encodes what is queued once and hands
/// it to each client. Memory per client is bounded: a client whose unsent messages exceed `client_queue_bytes` (a
/// slow reader, or one whose TCP window closed) is dropped, as is one that answers no ping for `idle_timeout_s`, and
/// one whose page sent nothing for `page_idle_timeout_s` (the page repeats its subscription every 15 s, so a
/// client that only answers pings cannot hold a connection for good); a page's messages are at most 256 bytes; HTTP
/// headers at most 8 KiB; the process table goes out in pages of `table_rows`.
///
/// Who may connect (docs/security.md, "The dashboard"): at most `max_connections` at once and
/// `max_connections_per_peer` from one address; every request must name this server in Host (the bound address,
/// a localhost name, or one of `allowed_hosts`; any numeric address when bound to every interface), so that a page of
/// another site whose name was rebound to this address (DNS rebinding) gets 403; a WebSocket upgrade from a browser
/// must come from this server's own page (Origin exactly http://<Host>).
class DashboardServer {
 public:
  static constexpr double kDefaultHistory_s = 30.0;
  struct Config {
    HttpEndpoint endpoint{"127.0.0.1", 8080};
    std::string dygraphs_dir{kDefaultDygraphsDir};
    std::size_t max_connections = 32;            ///< HTTP and WebSocket connections at once; more are closed.
    std::size_t max_connections_per_peer = 8;    ///< Of those, from one IP address.
    std::size_t client_queue_bytes = 1U << 20U;  ///< Unsent bytes per WebSocket client before it is dropped.
    std::size_t max_pending = 8192;              ///< States and events queued between two server ticks.
    double idle_timeout_s = 10.0;                ///< A WebSocket client silent (no pong) this long is dropped.
    double page_idle_timeout_s = 120.0;          ///< A page that sent no message this long is dropped.
    std::vector<std::string> allowed_hosts;      ///< Host names accepted besides the address and localhost.
    std::size_t table_rows = 50;                 ///< Rows of the process table per message (a page asks for more).
    double history_s = kDefaultHistory_s;        ///< Seconds of each pair's states and events kept for a new page.
    /// Bytes of one pair's history at most (the oldest go first): under client_queue_bytes, so that a page that
    /// subscribes gets all of it without being dropped as slow.
    std::size_t history_bytes = 768U << 10U;
    /// Commands from the page (teleop-supervise --allow-commands; docs/dds.md "Commands from the dashboard"): the
    /// token a page must send with each (64 hex digits); empty: the page is read-only and every command refused.
    std::string command_token;
    /// Forwards a command line to the process (pair, role) and returns its reply ("ok ..." or "error: ..."); called
    /// on a thread of its own, one command at a time, never on the server thread.
    std::function<std::string(const std::string& pair, const std::string& role, const std::string& line)>
        command_handler;
    double commands_per_s = 5.0;  ///< Per page at most (a burst of as many); more are refused.
  };
  struct Stats {
    std::uint64_t connections_accepted = 0;
    std::uint64_t connections_refused = 0;    ///< Over max_connections or max_connections_per_peer.
    std::uint64_t requests_foreign_host = 0;  ///< Host not this server's (403).
    std::uint64_t websocket_clients = 0;      ///< Open now.
    std::uint64_t clients_dropped_slow = 0;   ///< Unsent bytes over client_queue_bytes.
    std::uint64_t clients_dropped_idle = 0;   ///< No message from the page for page_idle_timeout_s.
    std::uint64_t websocket_refused = 0;      ///< Upgrade with a foreign Origin, or not on /ws.
    std::uint64_t requests_malformed = 0;     ///< Bad HTTP, or a page message that is not a request.
    std::uint64_t samples_dropped = 0;        ///< Publish* calls that found the queue full.
    std::uint64_t messages_sent = 0;          ///< WebSocket messages written, all clients.
    std::uint64_t commands_forwarded = 0;     ///< Commands handed to command_handler.
    std::uint64_t commands_refused = 0;       ///< Commands off, a wrong token, no pair chosen, or over the rate.
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
  /// The table of every process (the newest replaces one not yet sent; each page gets the rows it asked for and
  /// those of its pair). Never blocks on a client.
  void PublishProcesses(std::vector<ProcessView> views, double t_s);

  Stats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace teleop::dds
