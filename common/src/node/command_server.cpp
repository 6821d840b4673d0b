#include "teleop/node/command_server.hpp"

#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <sstream>
#include <vector>

#include "teleop/error.hpp"
#include "teleop/runtime/background_thread.hpp"

namespace teleop::node {

namespace {

constexpr std::size_t kMaxLine = 256;
constexpr int kPollMs = 100;

/// A number that is the whole token (no trailing garbage); false otherwise.
bool ParseNumber(const std::string& token, double& out) {
  if (token.empty()) return false;
  char* end = nullptr;
  errno = 0;
  out = std::strtod(token.c_str(), &end);
  return errno == 0 && end != nullptr && *end == '\0';
}

}  // namespace

CommandServer::CommandServer(TeleopNode& node, const Config& config) : node_(node), config_(config) {
  sockaddr_un addr{};
  if (config.path.empty() || config.path.size() >= sizeof(addr.sun_path)) {
    throw Error("command socket: path '" + config.path + "' is empty or longer than " +
                std::to_string(sizeof(addr.sun_path) - 1) + " characters");
  }
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, config.path.c_str(), config.path.size());
  listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) throw Error(std::string("command socket: socket(): ") + std::strerror(errno));
  struct stat st {};
  if (::lstat(config.path.c_str(), &st) == 0 && S_ISSOCK(st.st_mode)) ::unlink(config.path.c_str());
  // Bind with no permissions and chmod after: nobody can connect in between.
  const mode_t old_mask = ::umask(0777);
  const int bound = ::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));  // NOLINT
  const int bind_errno = errno;
  ::umask(old_mask);
  if (bound != 0 || ::chmod(config.path.c_str(), static_cast<mode_t>(config.mode & 0777)) != 0 ||
      ::listen(listen_fd_, 4) != 0) {
    const std::string why = std::strerror(bound != 0 ? bind_errno : errno);
    ::close(listen_fd_);
    throw Error("command socket: cannot serve '" + config.path + "': " + why);
  }
  thread_ = std::thread([this] {
    runtime::BecomeBackgroundThread("teleop-commands");
    Serve();
  });
}

CommandServer::~CommandServer() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  ::close(listen_fd_);
  ::unlink(config_.path.c_str());
}

void CommandServer::Serve() noexcept {
  while (!stop_.load()) {
    pollfd p{listen_fd_, POLLIN, 0};
    if (::poll(&p, 1, kPollMs) <= 0) continue;
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd < 0) continue;
    Handle(fd);
    ::close(fd);
  }
}

void CommandServer::Handle(int fd) noexcept {
  try {
    ucred cred{};
    socklen_t len = sizeof(cred);
    if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0 || (cred.uid != ::geteuid() && cred.uid != 0)) {
      ++refused_peers_;
      node_.RecordCommandEvent(Event::Kind::kCommandPeerRefused, static_cast<double>(cred.uid));
      spdlog::warn("command socket: refused a peer with uid {} (admitted: uid {} and root)", cred.uid, ::geteuid());
      const std::string reply = "refused: uid " + std::to_string(cred.uid) + " is not admitted\n";
      (void)::send(fd, reply.data(), reply.size(), MSG_NOSIGNAL);
      return;
    }
    std::string line;
    char buf[kMaxLine];
    while (line.size() < kMaxLine && line.find('\n') == std::string::npos) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 1000) <= 0) break;
      const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
      if (n <= 0) break;
      line.append(buf, static_cast<std::size_t>(n));
    }
    const std::string reply = Execute(line.substr(0, line.find('\n'))) + "\n";
    (void)::send(fd, reply.data(), reply.size(), MSG_NOSIGNAL);
  } catch (const std::exception& e) {
    spdlog::error("command socket: {}", e.what());
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
  spdlog::info("command '{}': {}", line.substr(0, kMaxLine), reply);
  return reply;
}

}  // namespace teleop::node
