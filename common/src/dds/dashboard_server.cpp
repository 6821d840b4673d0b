// teleop-supervise's dashboard server (docs/dds.md, "The dashboard"): Boost.Beast HTTP and WebSocket on one thread
// of its own. Everything below the Publish* functions runs on that thread only, so the sessions need no locks.
#include "teleop/dds/dashboard_server.hpp"

#include <sodium.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
// Asio trips -Wnull-dereference in its own inlined scheduler code (GCC 12, -O2), as in transport/udp_link.cpp.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/thread_pool.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#pragma GCC diagnostic pop
#include <chrono>
#include <deque>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "dashboard_assets.hpp"
#include "teleop/dds/dashboard_messages.hpp"
#include "teleop/dds/log_limiter.hpp"
#include "teleop/error.hpp"
#include "teleop/runtime/background_thread.hpp"

namespace teleop::dds {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;

namespace {

constexpr auto kTick = std::chrono::milliseconds(50);
constexpr auto kHttpTimeout = std::chrono::seconds(10);
constexpr std::uint32_t kHeaderLimit = 8192;
constexpr std::size_t kPageMessageMax = 256;
constexpr std::size_t kHistoryPairs = 256;  // pairs with a history at most (the supervisor follows 64 by default)

std::optional<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

constexpr std::int64_t kLogInterval_ns = 10'000'000'000;  // lines a client can cause: at most one per 10 s each

std::int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

bool IEquals(std::string_view a, std::string_view b) {
  return beast::iequals(beast::string_view(a.data(), a.size()), beast::string_view(b.data(), b.size()));
}

bool IsLocalhostName(std::string_view name) { return IEquals(name, "localhost") || IEquals(name, "localhost."); }

}  // namespace

bool HostHeaderAllowed(std::string_view host, const std::string& bound_address, std::uint16_t bound_port,
                       const std::vector<std::string>& allowed_hosts) {
  std::string_view name = host;
  std::string_view port_text;
  if (!host.empty() && host.front() == '[') {
    const std::size_t close = host.find(']');
    if (close == std::string_view::npos) return false;
    name = host.substr(1, close - 1);
    const std::string_view rest = host.substr(close + 1);
    if (!rest.empty()) {
      if (rest.front() != ':') return false;
      port_text = rest.substr(1);
      if (port_text.empty()) return false;
    }
  } else if (const std::size_t colon = host.find(':'); colon != std::string_view::npos) {
    name = host.substr(0, colon);
    port_text = host.substr(colon + 1);
    if (port_text.empty()) return false;
  }
  if (name.empty()) return false;
  if (port_text.empty()) {
    if (bound_port != 80) return false;
  } else if (port_text.size() > 5 || port_text.find_first_not_of("0123456789") != std::string_view::npos ||
             std::stoul(std::string(port_text)) != bound_port) {
    return false;
  }
  if (IsLocalhostName(name)) return true;
  for (const std::string& allowed : allowed_hosts)
    if (IEquals(name, allowed)) return true;
  boost::system::error_code ec;
  const auto address = net::ip::make_address(std::string(name), ec);
  if (ec) return false;  // a name: only localhost and the allowed ones (a rebound name must not reach us)
  if (host.front() != '[' && address.is_v6()) return false;
  const auto bound = net::ip::make_address(bound_address, ec);
  if (ec) return false;
  return address == bound || address.is_loopback() || bound.is_unspecified();
}

HttpEndpoint ParseHttpEndpoint(std::string_view text) {
  const std::string shown(text);
  std::string address = "127.0.0.1";
  std::string_view port_text = text;
  if (!text.empty() && text.front() == '[') {
    const std::size_t close = text.find(']');
    if (close == std::string_view::npos || close + 1 >= text.size() || text[close + 1] != ':')
      throw Error("--http '" + shown + "': expected [IPV6]:PORT");
    address = std::string(text.substr(1, close - 1));
    port_text = text.substr(close + 2);
  } else if (const std::size_t colon = text.rfind(':'); colon != std::string_view::npos) {
    if (text.find(':') != colon) throw Error("--http '" + shown + "': an IPv6 address goes in brackets, [::1]:8080");
    address = std::string(text.substr(0, colon));
    port_text = text.substr(colon + 1);
  }
  boost::system::error_code ec;
  (void)net::ip::make_address(address, ec);
  if (ec) throw Error("--http '" + shown + "': '" + address + "' is not a numeric IP address (e.g. 127.0.0.1)");
  if (port_text.empty() || port_text.size() > 5 || port_text.find_first_not_of("0123456789") != std::string_view::npos)
    throw Error("--http '" + shown + "': the port must be a number 1..65535");
  const int port = std::stoi(std::string(port_text));
  if (port < 1 || port > 65535) throw Error("--http '" + shown + "': the port must be a number 1..65535");
  return {address, static_cast<std::uint16_t>(port)};
}

namespace {

class WsSession;

/// What the sessions share with the server: the configuration, the assets, the counters and the client list.
struct ServerState {
  DashboardServer::Config config;
  std::string dygraph_js;
  std::string dygraph_css;
  bool have_dygraphs = false;
  std::uint16_t bound_port = 0;
  /// The newest process table (sorted by pair, role) and its time; a client gets its rows as soon as it connects.
  std::shared_ptr<const std::vector<ProcessView>> latest_views;
  double latest_views_t_s = 0.0;
  std::vector<std::weak_ptr<WsSession>> clients;  ///< Server thread only.
  /// The last seconds of each pair's state and event messages, already encoded (server thread only): a page that
  /// subscribes gets them at once. Bounded by Config::history_s and history_bytes per pair, and kHistoryPairs pairs.
  struct PairHistory {
    std::deque<std::pair<double, std::shared_ptr<const std::string>>> messages;  ///< (t_s, message), oldest first.
    std::size_t bytes = 0;
  };
  std::map<std::string, PairHistory> history;
  std::map<std::string, std::size_t> per_peer;  ///< Open connections by remote address; server thread only.
  LogLimiter drop_log{kLogInterval_ns};         ///< Server thread only.
  std::atomic<std::uint64_t> connections{0};    ///< Open HTTP + WebSocket connections.
  std::atomic<std::uint64_t> connections_accepted{0};
  std::atomic<std::uint64_t> connections_refused{0};
  std::atomic<std::uint64_t> requests_foreign_host{0};
  std::atomic<std::uint64_t> websocket_clients{0};
  std::atomic<std::uint64_t> clients_dropped_slow{0};
  std::atomic<std::uint64_t> clients_dropped_idle{0};
  std::atomic<std::uint64_t> websocket_refused{0};
  std::atomic<std::uint64_t> requests_malformed{0};
  std::atomic<std::uint64_t> messages_sent{0};
  std::atomic<std::uint64_t> commands_forwarded{0};
  std::atomic<std::uint64_t> commands_refused{0};
  net::io_context* io = nullptr;             ///< The server's, to post command replies back to its thread.
  net::thread_pool* command_pool = nullptr;  ///< One thread: the command handler runs there, one at a time.
  LogLimiter refuse_log{kLogInterval_ns};    ///< Server thread only.
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
};

/// Counts one open connection, in all and of its peer address, for as long as it lives (server thread).
class ConnectionSlot {
 public:
  ConnectionSlot(ServerState& s, std::string peer) : s_(&s), peer_(std::move(peer)) {
    s_->connections.fetch_add(1);
    ++s_->per_peer[peer_];
  }
  ~ConnectionSlot() {
    if (s_ == nullptr) return;
    s_->connections.fetch_sub(1);
    const auto it = s_->per_peer.find(peer_);
    if (it != s_->per_peer.end() && --it->second == 0) s_->per_peer.erase(it);
  }
  ConnectionSlot(ConnectionSlot&& other) noexcept : s_(other.s_), peer_(std::move(other.peer_)) { other.s_ = nullptr; }
  ConnectionSlot(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(ConnectionSlot&&) = delete;

 private:
  ServerState* s_;
  std::string peer_;
};

/// One WebSocket client: a bounded queue of encoded messages, written one at a time.
class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket&& socket, ServerState& s, ConnectionSlot slot)
      : ws_(std::move(socket)), s_(s), slot_(std::move(slot)) {}
  ~WsSession() {
    if (open_) s_.websocket_clients.fetch_sub(1);
  }
  WsSession(const WsSession&) = delete;
  WsSession& operator=(const WsSession&) = delete;

  void Run(const http::request<http::empty_body>& request) {
    beast::get_lowest_layer(ws_).expires_never();  // the WebSocket's own timeouts from here on
    websocket::stream_base::timeout timeout = websocket::stream_base::timeout::suggested(beast::role_type::server);
    timeout.handshake_timeout = kHttpTimeout;
    timeout.idle_timeout = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(s_.config.idle_timeout_s));
    timeout.keep_alive_pings = true;  // a ping at half the idle time; no answer by the end: dropped
    ws_.set_option(timeout);
    ws_.read_message_max(kPageMessageMax);
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& r) { r.set(http::field::server, "teleop-supervise"); }));
    ws_.async_accept(request, [self = shared_from_this()](beast::error_code ec) { self->OnAccept(ec); });
  }

  /// Queues `message` (server thread). A client already this far behind is dropped instead.
  void Send(const std::shared_ptr<const std::string>& message) {
    if (!open_) return;
    if (queued_bytes_ + message->size() > s_.config.client_queue_bytes) {
      std::uint64_t suppressed = 0;
      if (s_.drop_log.Allow(NowNs(), suppressed))
        spdlog::warn("dashboard: client {} is {} bytes behind (limit {}): dropped ({} more dropped in the last {} s)",
                     peer_, queued_bytes_, s_.config.client_queue_bytes, suppressed, kLogInterval_ns / 1'000'000'000);
      Close();
      s_.clients_dropped_slow.fetch_add(1);  // after Close: whoever sees the drop sees the client gone too
      return;
    }
    queue_.push_back(message);
    queued_bytes_ += message->size();
    if (!writing_) Write();
  }

  /// The pair this client's page asked for ("" = none).
  const std::string& pair() const { return pair_; }
  /// The first row of the process table this client's page shows.
  std::size_t table_offset() const { return table_offset_; }
  bool open() const { return open_; }

  /// Drops the client when its page sent nothing for page_idle_timeout_s (server thread).
  void DropIfIdle(std::int64_t now_ns) {
    if (!open_) return;
    if (static_cast<double>(now_ns - last_heard_ns_) * 1e-9 <= s_.config.page_idle_timeout_s) return;
    Close();
    s_.clients_dropped_idle.fetch_add(1);
  }

 private:
  void OnAccept(beast::error_code ec) {
    if (ec) return;
    open_ = true;
    s_.websocket_clients.fetch_add(1);
    boost::system::error_code ignored;
    const auto remote = beast::get_lowest_layer(ws_).socket().remote_endpoint(ignored);
    peer_ = remote.address().to_string(ignored) + ":" + std::to_string(remote.port());
    s_.clients.push_back(weak_from_this());
    const double t_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - s_.start).count();
    Send(std::make_shared<const std::string>(EncodeHello(
        t_s, s_.config.history_s, !s_.config.command_token.empty() && static_cast<bool>(s_.config.command_handler))));
    last_heard_ns_ = NowNs();
    if (s_.latest_views)
      Send(std::make_shared<const std::string>(
          EncodeProcesses(*s_.latest_views, s_.latest_views_t_s, 0, s_.config.table_rows, {})));
    Read();
  }

  void Read() {
    ws_.async_read(in_, [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnRead(ec); });
  }

  void OnRead(beast::error_code ec) {
    if (ec) {
      Close();
      return;
    }
    const std::string text = beast::buffers_to_string(in_.data());
    in_.consume(in_.size());
    if (auto request = ParseDashboardRequest(text)) {
      last_heard_ns_ = NowNs();
      if (request->kind == DashboardRequest::Kind::kTable) {
        table_offset_ = request->offset;
      } else if (request->kind == DashboardRequest::Kind::kCommand) {
        Command(*request);
      } else if (request->pair != pair_) {
        pair_ = std::move(request->pair);
        // The pair's last seconds first: a page opened mid-run shows them at once.
        if (const auto h = s_.history.find(pair_); h != s_.history.end())
          for (const auto& entry : h->second.messages) Send(entry.second);
      }
    } else {
      s_.requests_malformed.fetch_add(1);
    }
    Read();
  }

  /// A command from this page: refused (and said so) unless commands are on, the token matches, a pair is chosen and
  /// the page is within its rate; else handed to the command thread, and the reply, with who sent it, goes to every
  /// page of the pair and to the log.
  void Command(const DashboardRequest& request) {
    const double t_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - s_.start).count();
    std::string refusal;
    const std::string& token = s_.config.command_token;
    if (token.empty() || !s_.config.command_handler) {
      refusal = "error: commands are off (teleop-supervise --allow-commands)";
    } else if (request.token.size() != token.size() ||
               sodium_memcmp(request.token.data(), token.data(), token.size()) != 0) {
      refusal = "error: wrong token";
    } else if (pair_.empty()) {
      refusal = "error: no pair chosen";
    } else {
      const double per_s = s_.config.commands_per_s;
      command_credit_ = std::min(per_s, command_credit_ + (t_s - command_t_s_) * per_s);
      command_t_s_ = t_s;
      if (command_credit_ < 1.0) {
        refusal = "error: more than " + std::to_string(static_cast<int>(per_s)) + " commands per second";
      } else {
        command_credit_ -= 1.0;
      }
    }
    if (!refusal.empty()) {
      s_.commands_refused.fetch_add(1);
      std::uint64_t suppressed = 0;
      if (s_.refuse_log.Allow(NowNs(), suppressed))
        spdlog::warn("dashboard: command from {} refused: {} ({} more refused in the last {} s)", peer_, refusal,
                     suppressed, kLogInterval_ns / 1'000'000'000);
      Send(std::make_shared<const std::string>(EncodeCommand(pair_, request.role, request.line, peer_, refusal, t_s)));
      return;
    }
    s_.commands_forwarded.fetch_add(1);
    ServerState& s = s_;
    net::post(*s_.command_pool, [&s, pair = pair_, role = request.role, line = request.line, from = peer_, t_s] {
      std::string reply;
      try {
        reply = s.config.command_handler(pair, role, line);
      } catch (const std::exception& e) {
        reply = std::string("error: ") + e.what();
      }
      net::post(*s.io, [&s, pair, role, line, from, reply, t_s] {
        spdlog::info("dashboard: command from {} to {}/{}: '{}' -> {}", from, pair, role, line, reply);
        const auto message = std::make_shared<const std::string>(EncodeCommand(pair, role, line, from, reply, t_s));
        for (const auto& weak : s.clients)
          if (const auto c = weak.lock(); c && c->open() && c->pair() == pair) c->Send(message);
      });
    });
  }

  void Write() {
    writing_ = true;
    ws_.text(true);
    ws_.async_write(net::buffer(*queue_.front()),
                    [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnWrite(ec); });
  }

  void OnWrite(beast::error_code ec) {
    writing_ = false;
    if (ec || !open_) {
      Close();
      return;
    }
    s_.messages_sent.fetch_add(1);
    queued_bytes_ -= queue_.front()->size();
    queue_.pop_front();
    if (!queue_.empty() && open_) Write();
  }

  /// Closes the socket at once (no closing handshake: the client is too slow or gone); the pending read and write
  /// complete with an error and release the session.
  void Close() {
    if (open_) s_.websocket_clients.fetch_sub(1);
    open_ = false;
    // The message being written stays until its write completes (with an error, once the socket is closed).
    queue_.erase(writing_ && !queue_.empty() ? std::next(queue_.begin()) : queue_.begin(), queue_.end());
    queued_bytes_ = queue_.empty() ? 0 : queue_.front()->size();
    boost::system::error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).socket().close(ignored);
  }

  websocket::stream<beast::tcp_stream> ws_;
  ServerState& s_;
  ConnectionSlot slot_;
  beast::flat_buffer in_;
  std::deque<std::shared_ptr<const std::string>> queue_;
  std::size_t queued_bytes_ = 0;
  bool writing_ = false;
  bool open_ = false;
  std::string pair_;
  std::size_t table_offset_ = 0;
  double command_credit_ = 1e9;  ///< Commands this page may still send now (clamped to commands_per_s).
  double command_t_s_ = 0.0;
  std::int64_t last_heard_ns_ = 0;
  std::string peer_;
};

/// One HTTP connection: GET of the page, its script and style, dygraphs, or the upgrade to /ws.
class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, ServerState& s, ConnectionSlot slot)
      : stream_(std::move(socket)), s_(s), slot_(std::move(slot)) {}

  void Read() {
    parser_.emplace();
    parser_->header_limit(kHeaderLimit);
    parser_->body_limit(1024);
    stream_.expires_after(kHttpTimeout);
    http::async_read(stream_, buffer_, *parser_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnRead(ec); });
  }

 private:
  void OnRead(beast::error_code ec) {
    if (ec == http::error::end_of_stream) {
      stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
      return;
    }
    if (ec) {
      if (ec != beast::error::timeout && ec != net::error::operation_aborted) s_.requests_malformed.fetch_add(1);
      return;
    }
    http::request<http::empty_body> request = parser_->release();
    if (!OwnHost(request)) {
      s_.requests_foreign_host.fetch_add(1);
      request.keep_alive(false);
      Respond(request, http::status::forbidden, "text/plain; charset=utf-8",
              "this server answers only to its own address (Host): open it by its address or localhost\n");
      return;
    }
    if (websocket::is_upgrade(request)) {
      if (request.target() != "/ws" || !SameOrigin(request)) {
        s_.websocket_refused.fetch_add(1);
        Respond(request, http::status::forbidden, "text/plain; charset=utf-8",
                "a WebSocket is served only on /ws, to a page of this server\n");
        return;
      }
      std::make_shared<WsSession>(stream_.release_socket(), s_, std::move(slot_))->Run(request);
      return;
    }
    if (request.method() != http::verb::get && request.method() != http::verb::head) {
      Respond(request, http::status::method_not_allowed, "text/plain; charset=utf-8", "GET only\n");
      return;
    }
    const beast::string_view target = request.target();
    if (target == "/" || target == "/index.html" || target.starts_with("/?")) {
      Respond(request, http::status::ok, "text/html; charset=utf-8", std::string(DashboardPageHtml()));
    } else if (target == "/dashboard.js") {
      Respond(request, http::status::ok, "text/javascript; charset=utf-8", std::string(DashboardPageScript()));
    } else if (target == "/dashboard.css") {
      Respond(request, http::status::ok, "text/css; charset=utf-8", std::string(DashboardPageStyle()));
    } else if (target == "/favicon.ico") {
      Respond(request, http::status::no_content, "text/plain; charset=utf-8", "");
    } else if (target == "/dygraph.min.js" && s_.have_dygraphs) {
      Respond(request, http::status::ok, "text/javascript; charset=utf-8", s_.dygraph_js);
    } else if (target == "/dygraph.min.css" && s_.have_dygraphs) {
      Respond(request, http::status::ok, "text/css; charset=utf-8", s_.dygraph_css);
    } else if (target == "/dygraph.min.js" || target == "/dygraph.min.css") {
      Respond(request, http::status::not_found, "text/plain; charset=utf-8",
              "dygraphs is not installed where teleop-supervise looks (apt-get install libjs-dygraphs)\n");
    } else {
      Respond(request, http::status::not_found, "text/plain; charset=utf-8", "not found\n");
    }
  }

  /// Host names this server (DNS rebinding: a page of another site whose name now resolves to this address sends
  /// that name). HTTP/1.1 requires Host.
  bool OwnHost(const http::request<http::empty_body>& request) const {
    const auto host = request.find(http::field::host);
    if (host == request.end()) return false;
    const auto h = host->value();
    return HostHeaderAllowed(std::string_view(h.data(), h.size()), s_.config.endpoint.address, s_.bound_port,
                             s_.config.allowed_hosts);
  }

  /// A browser names the page that opens a WebSocket in Origin: only this server's own page may (another site open
  /// in the same browser must not read the telemetry), and it is served over http: exactly "http://" + Host. A
  /// client that is not a browser sends no Origin.
  static bool SameOrigin(const http::request<http::empty_body>& request) {
    const auto origin = request.find(http::field::origin);
    if (origin == request.end()) return true;
    const auto host = request.find(http::field::host);
    if (host == request.end()) return false;
    const auto o = origin->value();
    const auto h = host->value();
    return IEquals(std::string_view(o.data(), o.size()), "http://" + std::string(h.data(), h.size()));
  }

  void Respond(const http::request<http::empty_body>& request, http::status status, const char* type,
               std::string body) {
    response_.emplace(status, request.version());
    response_->set(http::field::server, "teleop-supervise");
    response_->set(http::field::content_type, type);
    response_->set(http::field::cache_control, "no-store");
    response_->set("X-Content-Type-Options", "nosniff");
    // dygraphs positions its canvases and legend with style attributes: 'unsafe-inline' for styles, not scripts.
    response_->set(
        "Content-Security-Policy",
        "default-src 'self'; connect-src 'self' ws: wss:; img-src 'self' data:; style-src 'self' 'unsafe-inline'; "
        "frame-ancestors 'none'");
    response_->keep_alive(request.keep_alive());
    const bool head = request.method() == http::verb::head;
    response_->body() = std::move(body);
    response_->prepare_payload();
    if (head) response_->body().clear();
    stream_.expires_after(kHttpTimeout);
    http::async_write(stream_, *response_,
                      [self = shared_from_this()](beast::error_code ec, std::size_t) { self->OnWrite(ec); });
  }

  void OnWrite(beast::error_code ec) {
    if (ec) return;
    if (!response_->keep_alive()) {
      stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
      return;
    }
    response_.reset();
    Read();
  }

  beast::tcp_stream stream_;
  ServerState& s_;
  ConnectionSlot slot_;
  beast::flat_buffer buffer_{kHeaderLimit};
  std::optional<http::request_parser<http::empty_body>> parser_;
  std::optional<http::response<http::string_body>> response_;
};

}  // namespace

struct DashboardServer::Impl {
  struct PendingEvent {
    std::string pair;
    std::string role;
    std::string kind;
    std::uint64_t cycle = 0;
    double value = 0.0;
    double t_s = 0.0;
  };

  explicit Impl(Config config) {
    state.config = std::move(config);
    state.io = &io;
    state.command_pool = &command_pool;
    const std::string dir = state.config.dygraphs_dir;
    auto js = ReadFile(dir + "/dygraph.min.js");
    auto css = ReadFile(dir + "/dygraph.min.css");
    state.have_dygraphs = js.has_value();
    if (js) state.dygraph_js = std::move(*js);
    if (css) state.dygraph_css = std::move(*css);
    if (!state.have_dygraphs)
      spdlog::warn("dashboard: no {}/dygraph.min.js (apt-get install libjs-dygraphs): the page shows no plots", dir);

    const auto& ep = state.config.endpoint;
    boost::system::error_code ec;
    const auto address = net::ip::make_address(ep.address, ec);
    if (ec) throw Error("dashboard: '" + ep.address + "' is not a numeric IP address");
    const tcp::endpoint endpoint(address, ep.port);
    const auto fail = [&](const char* what) {
      throw Error(std::string("dashboard: cannot ") + what + " " + ep.address + ":" + std::to_string(ep.port) + ": " +
                  ec.message());
    };
    if (acceptor.open(endpoint.protocol(), ec)) fail("open a socket for");
    if (acceptor.set_option(net::socket_base::reuse_address(true), ec)) fail("set SO_REUSEADDR on");
    if (acceptor.bind(endpoint, ec)) fail("listen on");
    if (acceptor.listen(net::socket_base::max_listen_connections, ec)) fail("listen on");
    bound_port = acceptor.local_endpoint(ec).port();
    state.bound_port = bound_port;

    Accept();
    Tick();
    thread = std::thread([this] {
      runtime::BecomeBackgroundThread("teleop-http");
      try {
        io.run();
      } catch (const std::exception& e) {
        spdlog::error("dashboard: server thread stopped: {}", e.what());
      }
    });
  }

  ~Impl() {
    command_pool.join();  // a command in flight completes; its reply is posted to the io, stopped next
    io.stop();
    if (thread.joinable()) thread.join();
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  void Accept() {
    acceptor.async_accept([this](beast::error_code ec, tcp::socket socket) {
      if (ec == net::error::operation_aborted) return;
      if (!ec) {
        boost::system::error_code ignored;
        std::string peer = socket.remote_endpoint(ignored).address().to_string(ignored);
        const auto mine = state.per_peer.find(peer);
        const std::size_t of_peer = mine == state.per_peer.end() ? 0 : mine->second;
        if (state.connections.load() >= state.config.max_connections ||
            of_peer >= state.config.max_connections_per_peer) {
          state.connections_refused.fetch_add(1);
          socket.close(ignored);
        } else {
          state.connections_accepted.fetch_add(1);
          std::make_shared<HttpSession>(std::move(socket), state, ConnectionSlot(state, std::move(peer)))->Read();
        }
      }
      Accept();
    });
  }

  void Tick() {
    timer.expires_after(kTick);
    timer.async_wait([this](beast::error_code ec) {
      if (ec) return;
      Deliver();
      Tick();
    });
  }

  /// Server thread: takes what the supervisor queued, encodes each message once, hands it to the clients.
  void Deliver() {
    std::vector<std::pair<StateTrace, double>> states;
    std::vector<PendingEvent> events;
    std::optional<std::pair<std::vector<ProcessView>, double>> processes;
    {
      const std::lock_guard<std::mutex> lock(mutex);
      states.swap(pending_states);
      events.swap(pending_events);
      processes.swap(pending_processes);
    }
    auto& clients = state.clients;
    clients.erase(std::remove_if(clients.begin(), clients.end(),
                                 [](const std::weak_ptr<WsSession>& c) {
                                   const auto s = c.lock();
                                   return !s || !s->open();
                                 }),
                  clients.end());
    const std::int64_t now_ns = NowNs();
    ForEachClient([&](WsSession& c) { c.DropIfIdle(now_ns); });
    if (processes) {
      state.latest_views = std::make_shared<const std::vector<ProcessView>>(std::move(processes->first));
      state.latest_views_t_s = processes->second;
      // Each page gets its rows of the table and its pair's: encoded once per distinct (offset, pair).
      std::map<std::pair<std::size_t, std::string>, std::shared_ptr<const std::string>> encoded;
      ForEachClient([&](WsSession& c) {
        auto& message = encoded[{c.table_offset(), c.pair()}];
        if (!message)
          message = std::make_shared<const std::string>(EncodeProcesses(
              *state.latest_views, state.latest_views_t_s, c.table_offset(), state.config.table_rows, c.pair()));
        c.Send(message);
      });
    }
    for (const auto& entry : states) {
      const StateTrace& trace = entry.first;  // not a structured binding: a lambda captures it below
      const double t_s = entry.second;
      const auto message = std::make_shared<const std::string>(EncodeState(trace, t_s));
      Remember(trace.pair, t_s, message);
      ForEachClient([&](WsSession& c) {
        if (c.pair() == trace.pair) c.Send(message);
      });
    }
    for (const PendingEvent& e : events) {
      const auto message =
          std::make_shared<const std::string>(EncodeEvent(e.pair, e.role, e.kind, e.cycle, e.value, e.t_s));
      Remember(e.pair, e.t_s, message);
      ForEachClient([&](WsSession& c) {
        if (c.pair() == e.pair) c.Send(message);
      });
    }
  }

  /// Appends to the pair's history and trims it to history_s and history_bytes; past kHistoryPairs pairs, the one
  /// whose newest message is oldest is forgotten.
  void Remember(const std::string& pair, double t_s, const std::shared_ptr<const std::string>& message) {
    if (state.config.history_s <= 0.0) return;
    auto& history = state.history;
    if (history.find(pair) == history.end() && history.size() >= kHistoryPairs) {
      auto oldest = history.begin();
      for (auto it = history.begin(); it != history.end(); ++it) {
        const double newest = it->second.messages.empty() ? -1e300 : it->second.messages.back().first;
        const double oldest_newest = oldest->second.messages.empty() ? -1e300 : oldest->second.messages.back().first;
        if (newest < oldest_newest) oldest = it;
      }
      history.erase(oldest);
    }
    ServerState::PairHistory& h = history[pair];
    h.messages.emplace_back(t_s, message);
    h.bytes += message->size();
    while (!h.messages.empty() &&
           (h.messages.front().first < t_s - state.config.history_s || h.bytes > state.config.history_bytes)) {
      h.bytes -= h.messages.front().second->size();
      h.messages.pop_front();
    }
  }

  template <typename F>
  void ForEachClient(F&& f) {
    // Send may drop a client; the list itself changes only here and on accept (same thread, not during the loop).
    const std::size_t n = state.clients.size();
    for (std::size_t i = 0; i < n; ++i) {
      if (auto c = state.clients[i].lock(); c && c->open()) f(*c);
    }
  }

  bool Admit() {
    if (pending_states.size() + pending_events.size() >= state.config.max_pending) {
      ++samples_dropped;
      return false;
    }
    return true;
  }

  ServerState state;  // before io: the sessions the io_context still holds refer to it when it is destroyed
  net::io_context io{1};
  net::thread_pool command_pool{1};
  tcp::acceptor acceptor{io};
  net::steady_timer timer{io};
  std::uint16_t bound_port = 0;
  std::thread thread;

  mutable std::mutex mutex;  // the pending queues, shared with the supervisor's thread
  std::vector<std::pair<StateTrace, double>> pending_states;
  std::vector<PendingEvent> pending_events;
  std::optional<std::pair<std::vector<ProcessView>, double>> pending_processes;
  std::uint64_t samples_dropped = 0;
};

DashboardServer::DashboardServer(Config config) : impl_(std::make_unique<Impl>(std::move(config))) {
  spdlog::info("dashboard: http://{}:{}/ (dygraphs {})", impl_->state.config.endpoint.address, impl_->bound_port,
               impl_->state.have_dygraphs ? "from " + impl_->state.config.dygraphs_dir : std::string("not found"));
}

DashboardServer::~DashboardServer() = default;

std::uint16_t DashboardServer::port() const noexcept { return impl_->bound_port; }

bool DashboardServer::have_dygraphs() const noexcept { return impl_->state.have_dygraphs; }

void DashboardServer::PublishState(const StateTrace& trace, double t_s) {
  auto entry = std::make_pair(trace, t_s);  // the copy outside the lock
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  if (impl_->Admit()) impl_->pending_states.push_back(std::move(entry));
}

void DashboardServer::PublishEvent(const std::string& pair, const std::string& role, const std::string& kind_name,
                                   std::uint64_t cycle, double value, double t_s) {
  Impl::PendingEvent e{pair, role, kind_name, cycle, value, t_s};
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  if (impl_->Admit()) impl_->pending_events.push_back(std::move(e));
}

void DashboardServer::PublishProcesses(std::vector<ProcessView> views, double t_s) {
  auto entry = std::make_pair(std::move(views), t_s);
  const std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->pending_processes = std::move(entry);
}

DashboardServer::Stats DashboardServer::stats() const {
  const ServerState& s = impl_->state;
  Stats out;
  out.connections_accepted = s.connections_accepted.load();
  out.connections_refused = s.connections_refused.load();
  out.requests_foreign_host = s.requests_foreign_host.load();
  out.clients_dropped_idle = s.clients_dropped_idle.load();
  out.websocket_clients = s.websocket_clients.load();
  out.clients_dropped_slow = s.clients_dropped_slow.load();
  out.websocket_refused = s.websocket_refused.load();
  out.requests_malformed = s.requests_malformed.load();
  out.messages_sent = s.messages_sent.load();
  out.commands_forwarded = s.commands_forwarded.load();
  out.commands_refused = s.commands_refused.load();
  {
    const std::lock_guard<std::mutex> lock(impl_->mutex);
    out.samples_dropped = impl_->samples_dropped;
  }
  return out;
}

}  // namespace teleop::dds
