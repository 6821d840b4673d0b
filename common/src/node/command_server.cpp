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

#include "teleop/error.hpp"

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
  thread_ = std::thread([this] { Serve(); });
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

std::string CommandServer::Execute(const std::string& line) {
  ++commands_;
  std::istringstream in(line);
  std::string verb;
  std::string a;
  std::string b;
  std::string extra;
  in >> verb >> a >> b >> extra;
  std::string reply;
  if (verb == "clutch" && (a == "on" || a == "off") && b.empty()) {
    node_.SetClutch(a == "on");
    reply = "ok: clutch " + a;
  } else if (verb == "fixture" && (a == "on" || a == "off") && extra.empty()) {
    double ramp = config_.default_ramp_s;
    if (!b.empty() && (!ParseNumber(b, ramp) || !std::isfinite(ramp) || ramp < 0.0)) {
      reply = "error: usage: fixture on|off [ramp_s >= 0]";
    } else {
      const TeleopNode::FixtureChange c = node_.RequestFixtureEnabled(a == "on", ramp);
      reply = (c.accepted ? "ok: " : "refused: ") + c.message;
    }
  } else if (verb == "fixture-stiffness" && extra.empty()) {
    double k = 0.0;
    double ramp = config_.default_ramp_s;
    if (!ParseNumber(a, k) || (!b.empty() && (!ParseNumber(b, ramp) || !std::isfinite(ramp) || ramp < 0.0))) {
      reply = "error: usage: fixture-stiffness <N/m> [ramp_s >= 0]";
    } else {
      const TeleopNode::FixtureChange c = node_.RequestFixtureStiffness(k, ramp);
      reply = (c.accepted ? "ok: " : "refused: ") + c.message;
    }
  } else {
    reply =
        "error: unknown or malformed command (commands: clutch on|off, fixture on|off [ramp_s], fixture-stiffness "
        "<N/m> [ramp_s])";
  }
  if (reply.rfind("error", 0) == 0) ++malformed_;
  spdlog::info("command '{}': {}", line.substr(0, kMaxLine), reply);
  return reply;
}

}  // namespace teleop::node
