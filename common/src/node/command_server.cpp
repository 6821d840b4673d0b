#include "teleop/node/command_server.hpp"

#include <fmt/format.h>
#include <poll.h>
#include <pwd.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string_view>
#include <system_error>
#include <vector>

#include "teleop/error.hpp"
#include "teleop/runtime/background_thread.hpp"

namespace teleop::node {

namespace {

constexpr int kPollMs = 100;

/// A number that is the whole token, in decimal (std::from_chars: no hex, no leading whitespace or '+', no locale);
/// false otherwise. "inf" and "nan" parse: the node refuses what is not finite, with its own message.
bool ParseNumber(const std::string& token, double& out) {
  if (token.empty()) return false;
  const char* const end = token.data() + token.size();
  const auto [ptr, ec] = std::from_chars(token.data(), end, out, std::chars_format::general);
  return ec == std::errc() && ptr == end;
}

/// The line as the log may show it: bytes outside printable ASCII as \xNN, so a command cannot move the cursor,
/// clear the screen or forge a log line in a terminal that shows the log.
std::string Printable(std::string_view line) {
  std::string out;
  out.reserve(line.size());
  for (const char c : line) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte >= 0x20 && byte < 0x7f && byte != '\\') {
      out += c;
    } else {
      out += fmt::format("\\x{:02x}", byte);
    }
  }
  return out;
}

std::string UserName(uid_t uid) {
  passwd entry{};
  passwd* found = nullptr;
  std::array<char, 1024> buffer{};
  if (::getpwuid_r(uid, &entry, buffer.data(), buffer.size(), &found) == 0 && found != nullptr) {
    return fmt::format("uid {} ({})", uid, found->pw_name);
  }
  return fmt::format("uid {}", uid);
}

/// What is at `path` before the bind: nothing, or a stale socket of this user (removed). Throws, naming the path
/// and what is in the way, for anything else: a file that is not a socket, another user's file (never removed: in a
/// shared directory such as /tmp another user can make the path first), a socket a live process answers (never
/// taken over), and a directory others may write without the sticky bit (anyone could swap the file after the
/// checks).
void ClearPath(const std::string& path, const sockaddr_un& addr) {
  const std::string where = "command socket '" + path + "': ";
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  struct stat d {};
  if (::stat(dir.empty() ? "." : dir.c_str(), &d) == 0 && (d.st_mode & (S_IWGRP | S_IWOTH)) != 0 &&
      (d.st_mode & S_ISVTX) == 0) {
    throw Error(where +
                "its directory is writable by others without the sticky bit (anyone could replace the "
                "socket): choose a directory only this user can write, e.g. $XDG_RUNTIME_DIR");
  }
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return;  // nothing there
  if (!S_ISSOCK(st.st_mode)) {
    throw Error(where + "exists and is not a socket: not replaced (remove it or choose another path)");
  }
  if (st.st_uid != ::geteuid()) {
    throw Error(where + "a socket of " + UserName(st.st_uid) + " is already there, not of this process's " +
                UserName(::geteuid()) +
                ": not removed; choose another path (a directory only this user can write, "
                "e.g. $XDG_RUNTIME_DIR)");
  }
  const int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (probe < 0) throw Error(where + "socket(): " + std::strerror(errno));
  const int rc = ::connect(probe, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));  // NOLINT: sockets API
  const int probe_errno = errno;
  ::close(probe);
  if (rc == 0) throw Error(where + "another process is serving commands on it: stop it or choose another path");
  if (probe_errno != ECONNREFUSED) {
    throw Error(where + "cannot tell whether it is in use: " + std::strerror(probe_errno));
  }
  if (::unlink(path.c_str()) != 0) throw Error(where + "cannot remove the stale socket: " + std::strerror(errno));
}

}  // namespace

struct CommandServer::Client {
  int fd = -1;
  std::string line;
  std::chrono::steady_clock::time_point deadline;
};

CommandServer::CommandServer(TeleopNode& node, const Config& config) : node_(node), config_(config) {
  sockaddr_un addr{};
  if (config.path.empty() || config.path.size() >= sizeof(addr.sun_path)) {
    throw Error("command socket: path '" + config.path + "' is empty or longer than " +
                std::to_string(sizeof(addr.sun_path) - 1) + " characters");
  }
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, config.path.c_str(), config.path.size());
  ClearPath(config.path, addr);
  listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) throw Error(std::string("command socket: socket(): ") + std::strerror(errno));
  // The file is created with exactly `mode` (the umask decides a new socket's permissions): no chmod by path after.
  const mode_t old_mask = ::umask(static_cast<mode_t>(~config.mode & 0777u));
  const int bound = ::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));  // NOLINT
  const int bind_errno = errno;
  ::umask(old_mask);
  if (bound != 0 || ::listen(listen_fd_, 16) != 0) {
    const std::string why = std::strerror(bound != 0 ? bind_errno : errno);
    if (bound == 0) ::unlink(config.path.c_str());
    ::close(listen_fd_);
    throw Error("command socket: cannot serve '" + config.path + "': " + why);
  }
  struct stat st {};
  if (::lstat(config.path.c_str(), &st) == 0) inode_ = st.st_ino;
  thread_ = std::thread([this] {
    runtime::BecomeBackgroundThread("teleop-commands");
    Serve();
  });
}

CommandServer::~CommandServer() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  ::close(listen_fd_);
  struct stat st {};
  // Only the file this server made: a later server's socket at the same path is left alone.
  if (::lstat(config_.path.c_str(), &st) == 0 && S_ISSOCK(st.st_mode) && st.st_ino == inode_) {
    ::unlink(config_.path.c_str());
  }
}

// One thread, every client at once: poll the listening socket and each connection, never block on one. A request
// ends at its newline (or kMaxLine bytes, or the end of the stream) and is executed then; one that has not ended
// kRequestDeadline_ms after its accept is closed with an error, unexecuted.
void CommandServer::Serve() noexcept {
  std::vector<Client> clients;
  try {
    clients.reserve(kMaxClients);
  } catch (...) {
    return;
  }
  std::array<pollfd, kMaxClients + 1> fds{};
  while (!stop_.load()) {
    const auto now = std::chrono::steady_clock::now();
    int timeout_ms = kPollMs;
    fds[0] = pollfd{listen_fd_, POLLIN, 0};
    for (std::size_t i = 0; i < clients.size(); ++i) {
      fds[i + 1] = pollfd{clients[i].fd, POLLIN, 0};
      const auto left = std::chrono::ceil<std::chrono::milliseconds>(clients[i].deadline - now).count();
      timeout_ms = static_cast<int>(std::clamp<std::int64_t>(left, 0, timeout_ms));
    }
    if (::poll(fds.data(), clients.size() + 1, timeout_ms) < 0) continue;
    const std::size_t polled = clients.size();
    for (std::size_t i = polled; i-- > 0;) {  // backwards: erase as we go
      Client& c = clients[i];
      bool done = false;
      if ((fds[i + 1].revents & (POLLIN | POLLHUP | POLLERR)) != 0) done = Read(c);
      if (done) {
        try {
          Reply(c.fd, Execute(c.line.substr(0, c.line.find('\n'))));
        } catch (const std::exception& e) {
          spdlog::error("command socket: {}", e.what());
        }
      } else if (std::chrono::steady_clock::now() >= c.deadline) {
        ++timed_out_;
        spdlog::warn("command socket: closed a client that sent no complete command line within {} ms",
                     kRequestDeadline_ms);
        Reply(c.fd, "error: no complete command line within " + std::to_string(kRequestDeadline_ms) + " ms");
        done = true;
      }
      if (done) {
        ::close(c.fd);
        clients.erase(clients.begin() + static_cast<std::ptrdiff_t>(i));
      }
    }
    if ((fds[0].revents & POLLIN) != 0) Accept(clients);
  }
  for (const Client& c : clients) ::close(c.fd);
}

void CommandServer::Accept(std::vector<Client>& clients) noexcept {
  for (;;) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;
    ucred cred{};
    socklen_t len = sizeof(cred);
    if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0 || (cred.uid != ::geteuid() && cred.uid != 0)) {
      ++refused_peers_;
      node_.RecordCommandEvent(Event::Kind::kCommandPeerRefused, static_cast<double>(cred.uid));
      spdlog::warn("command socket: refused a peer with uid {} (admitted: uid {} and root)", cred.uid, ::geteuid());
      Reply(fd, "refused: uid " + std::to_string(cred.uid) + " is not admitted");
      ::close(fd);
      continue;
    }
    if (clients.size() >= kMaxClients) {
      ++busy_;
      spdlog::warn("command socket: refused a client: {} are being served", kMaxClients);
      Reply(fd, "refused: busy (" + std::to_string(kMaxClients) + " clients are being served)");
      ::close(fd);
      continue;
    }
    try {
      clients.push_back(
          Client{fd, {}, std::chrono::steady_clock::now() + std::chrono::milliseconds(kRequestDeadline_ms)});
    } catch (...) {
      ::close(fd);
    }
  }
}

bool CommandServer::Read(Client& client) noexcept {
  std::array<char, kMaxLine> buf{};
  for (;;) {
    const std::size_t room = kMaxLine - client.line.size();
    const ssize_t n = ::recv(client.fd, buf.data(), room, MSG_DONTWAIT);
    if (n == 0) return true;  // the end of the stream ends the request
    if (n < 0) return errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR;  // an error: close it
    try {
      client.line.append(buf.data(), static_cast<std::size_t>(n));
    } catch (...) {
      return true;
    }
    if (client.line.find('\n') != std::string::npos || client.line.size() >= kMaxLine) return true;
  }
}

void CommandServer::Reply(int fd, const std::string& text) noexcept {
  try {
    const std::string line = text + "\n";
    (void)::send(fd, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  } catch (...) {
  }
}

namespace {

constexpr const char* kUsage =
    "commands: clutch on|off, fixture on|off [ramp_s], fixture-stiffness <N/m> [ramp_s], fixture-plane <offset_m> "
    "<normal: dof numbers> [rate_m_per_s], gain kp_N_per_m|kd_Ns_per_m|kv_Ns_per_m|kf[:<axis>] <value> [ramp_s]";

/// An optional ramp: absent (the default) or a finite number >= 0.
bool ParseRamp(const std::vector<std::string>& t, std::size_t at, double& ramp) {
  if (t.size() <= at) return true;
  return ParseNumber(t[at], ramp) && std::isfinite(ramp) && ramp >= 0.0;
}

/// `kp_N_per_m`, `kd_Ns_per_m:1`, ...: the gain and its axis (-1: every axis).
bool ParseGainName(const std::string& token, GainName& name, int& axis) {
  const std::size_t colon = token.find(':');
  const std::string key = token.substr(0, colon);
  bool known = false;
  for (const GainName g : {GainName::kKp, GainName::kKd, GainName::kKv, GainName::kKf}) {
    if (key == ToString(g)) {
      name = g;
      known = true;
    }
  }
  axis = -1;
  if (!known || colon == std::string::npos) return known;
  double a = 0.0;
  if (!ParseNumber(token.substr(colon + 1), a) || a < 0.0 || a >= kMaxDof || a != std::floor(a)) return false;
  axis = static_cast<int>(a);
  return true;
}

}  // namespace

std::string CommandServer::Execute(const std::string& line) {
  ++commands_;
  std::istringstream in(line);
  std::vector<std::string> t;
  for (std::string word; t.size() <= kMaxDof + 3 && in >> word;) t.push_back(word);
  const std::string verb = t.empty() ? std::string() : t[0];
  const std::size_t n = t.size();
  const auto verdict = [](const TeleopNode::FixtureChange& c) {
    return (c.accepted ? "ok: " : "refused: ") + c.message;
  };
  std::string reply;
  double ramp = config_.default_ramp_s;
  if (verb == "clutch" && n == 2 && (t[1] == "on" || t[1] == "off")) {
    node_.SetClutch(t[1] == "on");
    node_.RecordCommandEvent(Event::Kind::kClutchCommanded, t[1] == "on" ? 1.0 : 0.0);
    reply = "ok: clutch " + t[1];
  } else if (verb == "fixture" && (n == 2 || n == 3) && (t[1] == "on" || t[1] == "off")) {
    if (!ParseRamp(t, 2, ramp)) {
      reply = "error: usage: fixture on|off [ramp_s >= 0]";
    } else {
      reply = verdict(node_.RequestFixtureEnabled(t[1] == "on", ramp));
    }
  } else if (verb == "fixture-stiffness" && (n == 2 || n == 3)) {
    double k = 0.0;
    if (!ParseNumber(t[1], k) || !ParseRamp(t, 2, ramp)) {
      reply = "error: usage: fixture-stiffness <N/m> [ramp_s >= 0]";
    } else {
      reply = verdict(node_.RequestFixtureStiffness(k, ramp));
    }
  } else if (verb == "fixture-plane" && n >= 3) {
    // <offset_m> <n_1> .. <n_dof> [rate_m_per_s]: the normal has as many numbers as the process has DOF.
    const int dof = node_.dof();
    const std::size_t numbers = n - 2;  // after the offset
    const bool with_rate = numbers == static_cast<std::size_t>(dof) + 1;
    const std::size_t normal_size = with_rate ? numbers - 1 : numbers;
    double offset = 0.0;
    double rate = 0.0;
    DofVector normal = ZeroDof(dof);
    bool ok = ParseNumber(t[1], offset) && normal_size == static_cast<std::size_t>(dof);
    for (std::size_t i = 0; ok && i < normal_size; ++i) ok = ParseNumber(t[2 + i], normal[static_cast<int>(i)]);
    if (ok && with_rate) ok = ParseNumber(t[n - 1], rate) && rate > 0.0;
    if (!ok) {
      reply = "error: usage: fixture-plane <offset_m> <normal: " + std::to_string(dof) + " numbers> [rate_m_per_s > 0]";
    } else {
      reply = verdict(node_.RequestFixturePlane(normal, offset, rate));
    }
  } else if (verb == "gain" && (n == 3 || n == 4)) {
    GainName name = GainName::kKp;
    int axis = -1;
    double value = 0.0;
    if (!ParseGainName(t[1], name, axis) || !ParseNumber(t[2], value) || !ParseRamp(t, 3, ramp)) {
      reply = "error: usage: gain kp_N_per_m|kd_Ns_per_m|kv_Ns_per_m|kf[:<axis>] <value> [ramp_s >= 0]";
    } else {
      reply = verdict(node_.RequestGain(name, axis, value, ramp));
    }
  } else {
    reply = std::string("error: unknown or malformed command (") + kUsage + ")";
  }
  if (reply.rfind("error", 0) == 0) {
    ++malformed_;
    node_.RecordCommandEvent(Event::Kind::kCommandMalformed, 0.0);
  }
  spdlog::info("command '{}': {}", Printable(std::string_view(line).substr(0, kMaxLine)), reply);
  return reply;
}

}  // namespace teleop::node
