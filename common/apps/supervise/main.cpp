// teleop-supervise: every master/slave pair on a DDS domain, live in the terminal, optionally recorded to a file
// (docs/dds.md). Reads what the processes' DDS bridges publish; never talks to the processes otherwise.
#include <sodium.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <array>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "teleop/cli_help.hpp"
#include "teleop/dds/dashboard_server.hpp"
#include "teleop/dds/process_view.hpp"
#include "teleop/dds/supervisor.hpp"
#include "teleop/error.hpp"
#include "teleop/runtime/periodic_loop.hpp"
#include "teleop/version.hpp"

namespace {

std::atomic<bool> g_stop{false};

extern "C" void HandleStopSignal(int /*signal*/) { g_stop.store(true); }

enum class Format { kCsv, kJsonLines };

/// The record file: one line per process per refresh, plus (JSON lines only) events and summaries as they arrive.
class Recorder {
 public:
  Recorder(const std::string& path, Format format) : out_(path), format_(format) {
    if (!out_) throw teleop::Error("cannot open '" + path + "' for writing (--record)");
    if (format_ == Format::kCsv) out_ << teleop::dds::CsvHeader() << '\n';
  }
  void States(const std::vector<teleop::dds::ProcessView>& views, double t_s) {
    for (const auto& v : views) {
      if (v.status == teleop::dds::ProcessView::Status::kDiscovered && !v.have_state) continue;
      out_ << (format_ == Format::kCsv ? teleop::dds::CsvRow(v, t_s) : teleop::dds::JsonStateLine(v, t_s)) << '\n';
    }
    out_.flush();
  }
  void Event(const teleop::dds::ProcessView& v, const std::string& kind, std::uint64_t cycle, double value,
             double t_s) {
    if (format_ == Format::kJsonLines)
      out_ << teleop::dds::JsonEventLine(v.pair, v.role, kind, cycle, value, t_s) << '\n';
  }
  void Summary(const teleop::dds::ProcessView& v, double t_s) {
    if (format_ == Format::kJsonLines) out_ << teleop::dds::JsonSummaryLine(v, t_s) << '\n';
  }
  bool ok() const { return static_cast<bool>(out_); }

 private:
  std::ofstream out_;
  Format format_;
};

/// Feeds the dashboard from the supervisor's observer (every State and event as it is taken), keeping the recorder's
/// event callback.
void AttachDashboard(teleop::dds::Supervisor::Observer& observer, teleop::dds::DashboardServer& dashboard,
                     const std::function<double()>& clock) {
  observer.on_event = [previous = std::move(observer.on_event), &dashboard, clock](const teleop::dds::ProcessView& v,
                                                                                   const std::string& kind,
                                                                                   std::uint64_t cycle, double value) {
    if (previous) previous(v, kind, cycle, value);
    dashboard.PublishEvent(v.pair, v.role, kind, cycle, value, clock());
  };
  observer.on_state = [&dashboard, clock](const teleop::dds::ProcessView& /*view*/,
                                          const teleop::dds::StateTrace& trace) {
    dashboard.PublishState(trace, clock());
  };
}

/// One command line to a process's command socket (the one teleop-ctl uses) and its reply; at most 2 s each way.
std::string ForwardCommand(const std::string& path, const std::string& line) {
  sockaddr_un addr{};
  if (path.size() >= sizeof(addr.sun_path)) return "error: command socket path too long";
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  if (fd < 0) return "error: no socket";
  const timeval timeout{2, 0};
  (void)::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  (void)::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof(timeout));
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {  // NOLINT
    ::close(fd);
    return "error: cannot connect to the process's command socket " + path;
  }
  const std::string text = line + "\n";
  (void)::send(fd, text.data(), text.size(), MSG_NOSIGNAL);
  std::string reply;
  char buf[512];
  for (ssize_t n = 0; reply.size() < 4096 && (n = ::recv(fd, buf, sizeof(buf), 0)) > 0;)
    reply.append(buf, static_cast<std::size_t>(n));
  ::close(fd);
  while (!reply.empty() && (reply.back() == '\n' || reply.back() == '\r')) reply.pop_back();
  return reply.empty() ? "error: no reply from the process" : reply;
}

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

int Run(int argc, char** argv) {
  CLI::App app{
      "teleop-supervise: every teleop master/slave pair on a DDS domain (rate, loss, round trip, engagement, "
      "faults), live; see docs/dds.md"};
  app.set_version_flag("--version", teleop::VersionText("teleop-supervise"));
  teleop::StandardHelp(app);
  int domain_id = 0;
  double interval_s = 0.5;
  double stale_after_s = 1.0;
  double duration_s = 0.0;
  double settle_s = 2.0;
  bool once = false;
  bool quiet = false;
  std::string record_path;
  std::string format_name;
  app.add_option("--domain", domain_id, "DDS domain id (dds.domain_id of the processes)")->check(CLI::Range(0, 232));
  app.add_option("--interval", interval_s, "Seconds between refreshes of the table and the record")
      ->check(CLI::Range(0.01, 60.0));
  app.add_option("--stale-after", stale_after_s,
                 "A process without a State for this long (at least 3 state periods) is shown as stale")
      ->check(CLI::Range(0.05, 3600.0));
  app.add_option("--duration", duration_s, "Stop after this many seconds (0 = until Ctrl-C)")
      ->check(CLI::Range(0.0, 1e6));
  app.add_flag("--once", once, "Wait --settle seconds for discovery, print the table once and exit");
  app.add_option("--settle", settle_s, "With --once: seconds to listen before printing")->check(CLI::Range(0.0, 60.0));
  app.add_option("--record", record_path, "Also record every refresh to this file (CSV, or JSON lines)");
  app.add_option("--format", format_name, "Record format: csv or jsonl (default: csv for *.csv, else jsonl)")
      ->check(CLI::IsMember({"csv", "jsonl"}));
  app.add_flag("-q,--quiet", quiet, "Do not print the table (record only)");
  std::string http;
  std::string dygraphs_dir(teleop::dds::kDefaultDygraphsDir);
  app.add_option("--http", http,
                 "Serve the live dashboard on [ADDRESS:]PORT (ADDRESS 127.0.0.1 unless given, e.g. 127.0.0.1:8080)");
  app.add_option("--http-dygraphs", dygraphs_dir, "Where dygraph.min.js is (libjs-dygraphs)")->capture_default_str();
  std::vector<std::string> allowed_hosts;
  app.add_option("--http-allow-host", allowed_hosts,
                 "A host name the dashboard answers to besides its address and localhost (repeatable; any other "
                 "name in Host is refused, against DNS rebinding)");
  bool allow_commands = false;
  app.add_flag("--allow-commands", allow_commands,
               "Let the dashboard send clutch, fixture, stiffness, gain and plane commands to the processes named "
               "with --command-socket (a page needs the token printed at start)");
  std::vector<std::string> command_socket_args;
  app.add_option("--command-socket", command_socket_args,
                 "PAIR/ROLE=PATH: the command socket of a process (its --command-socket), repeatable");
  double history_s = teleop::dds::DashboardServer::kDefaultHistory_s;
  app.add_option("--http-history", history_s,
                 "Seconds of each pair's traces and events the dashboard keeps and shows a page that opens")
      ->check(CLI::Range(0.0, 3600.0))
      ->capture_default_str();
  std::size_t max_pairs = teleop::dds::Supervisor::Config{}.max_pairs;
  app.add_option("--max-pairs", max_pairs,
                 "Follow at most this many pairs (the first discovered); further ones are counted and ignored")
      ->check(CLI::Range(std::size_t{1}, std::size_t{100000}))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  spdlog::set_pattern("[%H:%M:%S.%e] [teleop-supervise] [%^%l%$] %v");

  try {
    std::optional<Recorder> recorder;
    if (!record_path.empty()) {
      const bool csv = format_name.empty() ? EndsWith(record_path, ".csv") : format_name == "csv";
      recorder.emplace(record_path, csv ? Format::kCsv : Format::kJsonLines);
    }
    const std::int64_t start_ns = teleop::runtime::MonotonicNowNs();
    const auto since_start_s = [start_ns] {
      return static_cast<double>(teleop::runtime::MonotonicNowNs() - start_ns) * 1e-9;
    };
    std::optional<teleop::dds::DashboardServer> dashboard;
    if (allow_commands && http.empty()) throw teleop::Error("--allow-commands needs --http (the dashboard)");
    std::map<std::string, std::string> command_sockets;  // "pair/role" -> path
    for (const std::string& arg : command_socket_args) {
      const std::size_t eq = arg.find('=');
      const std::size_t slash = arg.find('/');
      if (eq == std::string::npos || slash == std::string::npos || slash > eq || eq + 1 == arg.size())
        throw teleop::Error("--command-socket '" + arg + "': expected PAIR/ROLE=PATH (e.g. rigA/master=/run/m.sock)");
      command_sockets[arg.substr(0, eq)] = arg.substr(eq + 1);
    }
    if (!http.empty()) {
      teleop::dds::DashboardServer::Config config;
      config.endpoint = teleop::dds::ParseHttpEndpoint(http);
      config.dygraphs_dir = dygraphs_dir;
      config.allowed_hosts = allowed_hosts;
      config.history_s = history_s;
      if (allow_commands) {
        if (sodium_init() < 0) throw teleop::Error("libsodium failed to initialise");
        std::array<unsigned char, 32> key{};
        randombytes_buf(key.data(), key.size());
        std::array<char, 65> hex{};
        sodium_bin2hex(hex.data(), hex.size(), key.data(), key.size());
        config.command_token = hex.data();
        config.command_handler = [command_sockets](const std::string& pair, const std::string& role,
                                                   const std::string& line) {
          const auto it = command_sockets.find(pair + "/" + role);
          if (it == command_sockets.end())
            return "error: no --command-socket " + pair + "/" + role + "=PATH given to teleop-supervise";
          return ForwardCommand(it->second, line);
        };
      }
      dashboard.emplace(config);
      if (allow_commands)
        std::cout << "dashboard commands allowed: open http://" << config.endpoint.address << ":" << dashboard->port()
                  << "/#token=" << config.command_token << "\n"
                  << std::flush;
    }
    teleop::dds::Supervisor::Observer observer;
    if (recorder) {
      observer.on_event = [&](const teleop::dds::ProcessView& v, const std::string& kind, std::uint64_t cycle,
                              double value) { recorder->Event(v, kind, cycle, value, since_start_s()); };
      observer.on_summary = [&](const teleop::dds::ProcessView& v) { recorder->Summary(v, since_start_s()); };
    }
    if (dashboard) AttachDashboard(observer, *dashboard, since_start_s);
    teleop::dds::Supervisor::Config supervisor_config;
    supervisor_config.domain_id = domain_id;
    supervisor_config.stale_after_s = stale_after_s;
    supervisor_config.max_pairs = max_pairs;
    teleop::dds::Supervisor supervisor(supervisor_config, observer);

    struct sigaction action {};
    action.sa_handler = HandleStopSignal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);

    const bool tty = isatty(STDOUT_FILENO) == 1;
    constexpr auto kPollInterval = std::chrono::milliseconds(20);
    double next_refresh_s = once ? settle_s : 0.0;
    constexpr double kDashboardInterval_s = 0.1;  // the process table and the data-age trace of the dashboard
    double next_dashboard_s = 0.0;
    while (!g_stop.load()) {
      supervisor.Poll();
      const double t_s = since_start_s();
      const bool last = once ? t_s >= settle_s : (duration_s > 0.0 && t_s >= duration_s);
      if (t_s >= next_refresh_s || last) {
        const auto views = supervisor.Snapshot(teleop::runtime::MonotonicNowNs());
        if (recorder) recorder->States(views, t_s);
        if (!quiet) {
          if (tty && !once) std::cout << "\x1b[H\x1b[2J";
          std::cout << "domain " << domain_id << ", " << views.size() << " processes, t = " << static_cast<int>(t_s)
                    << " s\n"
                    << teleop::dds::FormatTable(views) << (tty || once ? "" : "\n") << std::flush;
        }
        next_refresh_s = t_s + interval_s;
      }
      if (dashboard && t_s >= next_dashboard_s) {
        dashboard->PublishProcesses(supervisor.Snapshot(teleop::runtime::MonotonicNowNs()), t_s);
        next_dashboard_s = t_s + kDashboardInterval_s;
      }
      if (last) break;
      std::this_thread::sleep_for(kPollInterval);
    }
    if (dashboard) {
      const auto st = dashboard->stats();
      spdlog::info(
          "dashboard: {} connections ({} refused), {} requests for a foreign Host, {} clients dropped as too slow, "
          "{} as idle, {} samples dropped",
          st.connections_accepted, st.connections_refused, st.requests_foreign_host, st.clients_dropped_slow,
          st.clients_dropped_idle, st.samples_dropped);
    }
    if (supervisor.topics_ignored() > 0)
      spdlog::warn("{} topics of pairs beyond --max-pairs {} were ignored", supervisor.topics_ignored(), max_pairs);
    if (recorder && !recorder->ok()) throw teleop::Error("writing the record file '" + record_path + "' failed");
    return 0;
  } catch (const teleop::Error& e) {
    spdlog::critical("{}", e.what());
    return 2;
  }
}

}  // namespace

int main(int argc, char** argv) {
  // Everything expected is handled in Run(); this only keeps an unexpected exception from ending the program
  // without a message.
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "teleop-supervise: unexpected error: " << e.what() << "\n";
    return 3;
  } catch (...) {
    std::cerr << "teleop-supervise: unexpected error\n";
    return 3;
  }
}
