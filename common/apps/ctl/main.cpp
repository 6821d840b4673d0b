// teleop-ctl --socket PATH <command...>: one command line to a process's command socket, its reply on stdout.
// Exit status: 0 ok, 1 refused or error (the reply says which), 2 no connection.

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include "teleop/cli_help.hpp"
#include "teleop/version.hpp"

namespace {

int Run(int argc, char** argv) {
  CLI::App app{
      "teleop-ctl: a run-time command to teleop-master/teleop-slave (docs/clutch.md). Commands:\n"
      "  clutch on|off\n"
      "  fixture on|off [ramp_s]\n"
      "  fixture-stiffness <N/m> [ramp_s]\n"
      "  fixture-plane <offset_m> <normal: dof numbers> [rate_m_per_s]\n"
      "  gain kp_N_per_m|kd_Ns_per_m|kv_Ns_per_m|kf[:<axis>] <value> [ramp_s]"};
  app.set_version_flag("--version", teleop::VersionText("teleop-ctl"));
  teleop::StandardHelp(app);
  std::string path;
  std::vector<std::string> words;
  app.add_option("--socket", path, "the process's command socket")->required();
  app.add_option("command", words, "the command and its arguments")->required();
  CLI11_PARSE(app, argc, argv);
  std::string line;
  for (const std::string& w : words) line += (line.empty() ? "" : " ") + w;
  line += "\n";
  sockaddr_un addr{};
  if (path.size() >= sizeof(addr.sun_path)) {
    std::fprintf(stderr, "teleop-ctl: socket path too long\n");
    return 2;
  }
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  if (fd < 0 || ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {  // NOLINT
    std::fprintf(stderr, "teleop-ctl: cannot connect to '%s': %s\n", path.c_str(), std::strerror(errno));
    return 2;
  }
  (void)::send(fd, line.data(), line.size(), MSG_NOSIGNAL);
  std::string reply;
  char buf[512];
  for (ssize_t n = 0; (n = ::recv(fd, buf, sizeof(buf), 0)) > 0;) reply.append(buf, static_cast<std::size_t>(n));
  ::close(fd);
  std::fputs(reply.c_str(), stdout);
  return reply.rfind("ok", 0) == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {  // an allocation failure; CLI11's own errors are handled in Run
    std::fprintf(stderr, "teleop-ctl: %s\n", e.what());
    return 2;
  }
}
