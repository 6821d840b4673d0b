// teleop-canbus: an emulated CAN bus on UDP 127.0.0.1 or a Unix socket (docs/can.md, "Emulated bus between
// processes"; who may join: docs/security.md, "What CAN trusts").
//
//   teleop-canbus --bind unix:/run/teleop/canbus.sock --socket-mode 0660 --socket-group teleop --allow-uid 1001
//   teleop-canbus [--port 47300] [--bitrate 1000000] [--data-bitrate 5000000] [--load-ceiling 1.0]
//   teleop-canbus --port 47300 --inject-errors 32      # destroy the next 32 transmissions (then exit)
//   teleop-canbus --port 47300 --bus-off 0             # put node 0 bus-off; --restart 0 brings it back
//   teleop-canbus --candump-log bus.log                # also log every frame in candump -L format
#include <grp.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <csignal>
#include <iostream>
#include <string>
#include <thread>

#include "teleop/cli_help.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/can_bus_server.hpp"
#include "teleop/transport/can_udp_bus_port.hpp"
#include "teleop/version.hpp"

namespace {

std::atomic<bool> g_stop{false};

void OnSignal(int /*signal*/) { g_stop = true; }

}  // namespace

static int Run(int argc, char** argv) {
  using namespace teleop::transport;
  CLI::App app{"teleop-canbus: emulated CAN bus for teleop-master/teleop-slave (transport emulated-can)"};
  app.set_version_flag("--version", teleop::VersionText("teleop-canbus"));
  teleop::StandardHelp(app);
  CanBusServerConfig config;
  double duration_s = 0.0;
  double stats_every_s = 5.0;
  int inject_errors = -1;
  int bus_off_node = -1;
  int restart_node = -1;
  app.add_option("--bind", config.bind_address,
                 "IPv4 address to listen on (UDP, --port), or unix:PATH: a Unix-domain seqpacket socket (the "
                 "processes' link.can.bus); a stale socket file is replaced, a live daemon's is refused")
      ->capture_default_str();
  std::string socket_mode = "0600";
  std::string socket_group;
  app.add_option("--socket-mode", socket_mode,
                 "unix: only: the socket file's permission bits, octal (who may join: write permission)")
      ->capture_default_str();
  app.add_option("--socket-group", socket_group, "unix: only: the socket file's group (name or gid)");
  app.add_option("--port", config.port, "UDP port: the PORT of the processes' link.can.bus HOST:PORT")
      ->capture_default_str();
  app.add_option("--bitrate", config.bus.nominal_bitrate_bit_per_s, "nominal bit rate, bit/s")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--data-bitrate", config.bus.data_bitrate_bit_per_s, "CAN FD data bit rate, bit/s")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--load-ceiling", config.bus.load_ceiling, "fraction of bus time the nodes get (rest: other traffic)")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 1.0));
  app.add_option("--tx-queue", config.bus.tx_queue_frames, "transmit queue per node, frames")->capture_default_str();
  app.add_option("--max-nodes", config.max_nodes, "nodes that may attach")->capture_default_str();
  app.add_option("--node-timeout-ms", config.node_timeout_ms,
                 "UDP: detach a node silent for this long (0: never; nodes send a hello every 500 ms when idle)")
      ->capture_default_str()
      ->check(CLI::Range(0, 3'600'000));
  app.add_option("--duration-s", duration_s, "stop after this long (0: until SIGINT/SIGTERM)")->capture_default_str();
  app.add_option("--stats-every-s", stats_every_s, "print bus statistics this often (0: only at exit)")
      ->capture_default_str();
  app.add_option("--candump-log", config.candump_log_path,
                 "append every frame the bus carries to this file, candump -L format (canplayer, log2asc)");
  app.add_option("--candump-interface", config.candump_interface, "interface name written in the candump log")
      ->capture_default_str();
  app.add_option("--allow-uid", config.allowed_uids,
                 "a user (uid) whose processes may attach, repeatable (default: only the daemon's own user); the "
                 "owner of the sending socket, from /proc/net/udp (docs/security.md, \"What CAN trusts\")");
  app.add_option("--controller-uid", config.controller_uids,
                 "a user (uid) whose attached nodes may send bus-off/restart/error commands, repeatable (default: "
                 "only the daemon's own user)");
  bool allow_remote = false;
  bool local_only = false;
  app.add_flag("--allow-remote", allow_remote,
               "admit nodes of other machines (default: only when --bind is not a loopback address)");
  app.add_flag("--local-only", local_only, "admit only sockets of this host, whatever --bind is");
  app.add_option("--inject-errors", inject_errors, "client mode: destroy the next N transmissions on a running bus");
  app.add_option("--bus-off", bus_off_node, "client mode: put node N of a running bus bus-off");
  app.add_option("--restart", restart_node, "client mode: restart bus-off node N of a running bus");
  CLI11_PARSE(app, argc, argv);
  if (allow_remote) config.allow_remote = CanBusServerConfig::Remote::kAllow;
  if (local_only) config.allow_remote = CanBusServerConfig::Remote::kRefuse;
  {
    std::size_t used = 0;
    unsigned long mode = 0;
    try {
      mode = std::stoul(socket_mode, &used, 8);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != socket_mode.size() || mode > 0777) {
      std::cerr << "teleop-canbus: --socket-mode '" << socket_mode << "' is not an octal mode 0..0777\n";
      return 2;
    }
    config.socket_mode = static_cast<unsigned>(mode);
  }
  if (!socket_group.empty()) {
    if (socket_group.find_first_not_of("0123456789") == std::string::npos && socket_group.size() < 10) {
      config.socket_gid = std::stoi(socket_group);
    } else if (const group* g = ::getgrnam(socket_group.c_str()); g != nullptr) {
      config.socket_gid = static_cast<int>(g->gr_gid);
    } else {
      std::cerr << "teleop-canbus: --socket-group '" << socket_group << "': no such group\n";
      return 2;
    }
  }

  try {
    const std::string where = config.bind_address.rfind("unix:", 0) == 0
                                  ? config.bind_address
                                  : fmt::format("{}:{}", config.bind_address, config.port);
    if (inject_errors >= 0 || bus_off_node >= 0 || restart_node >= 0) {
      UdpCanBusPort client(config.bind_address, config.port, 1000.0);
      bool ok = true;
      if (inject_errors >= 0)
        ok &= client.SendControl(bus_datagram::Action::kInjectErrors, static_cast<std::uint32_t>(inject_errors));
      if (bus_off_node >= 0)
        ok &= client.SendControl(bus_datagram::Action::kBusOff, static_cast<std::uint32_t>(bus_off_node));
      if (restart_node >= 0)
        ok &= client.SendControl(bus_datagram::Action::kRestart, static_cast<std::uint32_t>(restart_node));
      if (!ok) {
        spdlog::error("could not send the control datagram to {}", where);
        return 1;
      }
      spdlog::info("sent to teleop-canbus {}", where);
      return 0;
    }
    CanBusServer server(config);
    std::signal(SIGINT, OnSignal);
    std::signal(SIGTERM, OnSignal);
    if (server.replaced_stale_socket()) spdlog::info("replaced the stale socket {}", server.unix_path());
    spdlog::info("teleop-canbus listening on {}, {:.0f} bit/s nominal, {:.0f} bit/s FD data, load ceiling {:.2f}",
                 server.unix_path().empty()
                     ? fmt::format("{}:{}", config.bind_address, server.port())
                     : fmt::format("unix:{} (mode {:04o})", server.unix_path(), config.socket_mode),
                 config.bus.nominal_bitrate_bit_per_s, config.bus.data_bitrate_bit_per_s, config.bus.load_ceiling);
    if (!config.candump_log_path.empty()) {
      spdlog::info("logging every frame to {} (candump -L, interface {})", config.candump_log_path,
                   config.candump_interface);
    }
    const auto start = std::chrono::steady_clock::now();
    auto next_stats = start + std::chrono::duration<double>(stats_every_s);
    while (!g_stop) {
      server.Step(20'000'000);
      const auto now = std::chrono::steady_clock::now();
      if (duration_s > 0 && now - start >= std::chrono::duration<double>(duration_s)) break;
      if (stats_every_s > 0 && now >= next_stats) {
        spdlog::info("{}", server.Describe());
        next_stats = now + std::chrono::duration<double>(stats_every_s);
      }
    }
    spdlog::info("{}", server.Describe());
    return 0;
  } catch (const teleop::Error& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
}

int main(int argc, char** argv) {
  // Everything expected is handled in Run(); this only keeps an unexpected exception (e.g. out of memory while
  // setting up) from ending the program without a message.
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "teleop-canbus: unexpected error: " << e.what() << "\n";
    return 3;
  } catch (...) {
    std::cerr << "unexpected error\n";
    return 3;
  }
}
