// Who may join the emulated CAN bus and who may command it (teleop-canbus, docs/security.md "What CAN trusts"): a
// process of another user cannot attach (its hello is traced to its socket's owner through /proc/net/udp and
// refused), and control commands (bus-off, restart, error injection) come only from a controller's nodes.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <thread>

#include "teleop/error.hpp"
#include "teleop/transport/can_bus_datagram.hpp"
#include "teleop/transport/can_bus_server.hpp"
#include "teleop/transport/can_udp_bus_port.hpp"

namespace teleop::transport {
namespace {

constexpr std::uint32_t kNobody = 65534;

struct Bus {
  explicit Bus(CanBusServerConfig config) {
    config.port = 0;
    server = std::make_unique<CanBusServer>(config);
  }
  void Start() {
    thread = std::thread([this] { server->Run(stop); });
  }
  ~Bus() {
    stop = true;
    if (thread.joinable()) thread.join();
  }
  std::unique_ptr<CanBusServer> server;
  std::atomic<bool> stop{false};
  std::thread thread;
};

// A child process that drops to `uid` and tries to attach; its exit status: 0 attached, 1 refused, 2 no setuid. It
// is forked before the bus's thread starts (a child of a one-thread process may allocate), and retries for 300 ms.
int AttachAs(std::uint32_t uid, Bus& bus) {
  const std::uint16_t port = bus.server->port();
  const pid_t child = ::fork();
  if (child == 0) {
    if (::setgid(uid) != 0 || ::setuid(uid) != 0) ::_exit(2);
    try {
      UdpCanBusPort port_as_user("127.0.0.1", port, 300.0);
      ::_exit(0);
    } catch (const Error&) {
      ::_exit(1);
    }
  }
  bus.Start();
  int status = 0;
  ::waitpid(child, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(CanBusAccess, AProcessOfAnotherUserCannotAttach) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to run a process as another user";
  Bus bus{CanBusServerConfig{}};
  const std::uint16_t port = bus.server->port();
  EXPECT_EQ(AttachAs(kNobody, bus), 1) << "an unprivileged user's process attached";
  EXPECT_GE(bus.server->refused_hellos(), 1u);
  EXPECT_EQ(bus.server->node_count(), 0);
  // The daemon's own user attaches as before.
  UdpCanBusPort own("127.0.0.1", port, 2000.0);
  EXPECT_EQ(bus.server->node_count(), 1);
}

TEST(CanBusAccess, AnAllowedUserMayAttach) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to run a process as another user";
  CanBusServerConfig config;
  config.allowed_uids = {0, kNobody};
  Bus bus{config};
  EXPECT_EQ(AttachAs(kNobody, bus), 0);
  EXPECT_EQ(bus.server->refused_hellos(), 0u);
}

TEST(CanBusAccess, ControlCommandsComeOnlyFromAController) {
  CanBusServerConfig config;
  config.controller_uids = {static_cast<std::uint32_t>(::geteuid()) + 1};  // not us
  Bus bus{config};
  bus.Start();
  UdpCanBusPort a("127.0.0.1", bus.server->port(), 2000.0);
  ASSERT_TRUE(a.SendControl(bus_datagram::Action::kBusOff, 0));
  ASSERT_TRUE(a.SendControl(bus_datagram::Action::kInjectErrors, 3));
  for (int i = 0; i < 200 && bus.server->refused_controls() < 2; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(bus.server->refused_controls(), 2u);
  EXPECT_FALSE(bus.server->bus().is_bus_off(0)) << "a refused command must not act";

  // The daemon's own user is the controller by default.
  Bus own{CanBusServerConfig{}};
  own.Start();
  UdpCanBusPort b("127.0.0.1", own.server->port(), 2000.0);
  ASSERT_TRUE(b.SendControl(bus_datagram::Action::kBusOff, 0));
  for (int i = 0; i < 200 && !own.server->bus().is_bus_off(0); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_TRUE(own.server->bus().is_bus_off(0));
  EXPECT_EQ(own.server->refused_controls(), 0u);
}

TEST(CanBusAccess, RemoteNodesOnlyWhereTheNetworkIsTheBus) {
  CanBusServerConfig config;
  config.allow_remote = CanBusServerConfig::Remote::kRefuse;
  Bus bus{config};
  bus.Start();
  // A local socket is still traced to its owner and admitted.
  UdpCanBusPort own("127.0.0.1", bus.server->port(), 2000.0);
  EXPECT_EQ(bus.server->node_count(), 1);
  EXPECT_EQ(bus.server->refused_hellos(), 0u);
}

}  // namespace
}  // namespace teleop::transport
