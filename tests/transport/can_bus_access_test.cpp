// Who may join the emulated CAN bus and who may command it (teleop-canbus, docs/security.md "What CAN trusts"): a
// process of another user cannot attach (its hello is traced to its socket's owner through /proc/net/udp and
// refused), and control commands (bus-off, restart, error injection) come only from a controller's nodes. The same
// over a Unix-domain socket (`unix:PATH`): the socket file's mode and group decide who may connect at all, the
// kernel names the connecting process (SO_PEERCRED), and a stale socket file is replaced while a live daemon's is not.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <span>
#include <string>
#include <thread>

#include "teleop/error.hpp"
#include "teleop/transport/can_bus_datagram.hpp"
#include "teleop/transport/can_bus_server.hpp"
#include "teleop/transport/can_udp_bus_port.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::transport {
namespace {

constexpr std::uint32_t kNobody = 65534;

struct Bus {
  explicit Bus(CanBusServerConfig config) {
    if (config.bind_address.rfind("unix:", 0) != 0) config.port = 0;
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

// A UDP socket on 127.0.0.1:`own_port` (0: any) connected to the daemon, as a node's; -1 when the port is taken.
int UdpNode(std::uint16_t bus_port, std::uint16_t own_port = 0) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = htons(own_port);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {  // NOLINT: sockets API
    ::close(fd);
    return -1;
  }
  addr.sin_port = htons(bus_port);
  (void)::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);  // NOLINT: sockets API
  return fd;
}

std::uint16_t PortOf(int fd) {
  sockaddr_in addr{};
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);  // NOLINT: sockets API
  return ntohs(addr.sin_port);
}

void SendMessage(int fd, const bus_datagram::Message& m) {
  std::array<std::uint8_t, bus_datagram::kMaxSize> out{};
  (void)::send(fd, out.data(), bus_datagram::Encode(m, out), MSG_DONTWAIT);
}

/// Frames (not welcomes) waiting on `fd`.
int FramesWaiting(int fd) {
  int frames = 0;
  std::array<std::uint8_t, bus_datagram::kMaxSize> in{};
  for (ssize_t n = 0; (n = ::recv(fd, in.data(), in.size(), MSG_DONTWAIT)) > 0;) {
    bus_datagram::Message m{};
    if (bus_datagram::Decode(std::span<const std::uint8_t>(in.data(), static_cast<std::size_t>(n)), m) &&
        m.type == bus_datagram::Type::kFrame) {
      ++frames;
    }
  }
  return frames;
}

bus_datagram::Message Hello() {
  bus_datagram::Message m{};
  m.type = bus_datagram::Type::kHello;
  return m;
}

// Issue 31 item 14: a node is the socket that said hello, not its port. The master's node dies without a bye (its
// socket closes); another socket binds the freed port and sends a frame and a bus-off for node 0. As root the
// successor is nobody's (the attack: before, its frames went out as the master's and its bus-off was obeyed with
// the master's controller rights); otherwise our own user's, a different socket all the same. The daemon detaches
// the dead node at its next look-up (every kOwnerCheckPeriod_ns, before the queue is drained): the frame comes from
// no node (counted malformed) and reaches no one, the bus-off is refused.
TEST(CanBusAccess, ADeadNodeIsNotInheritedByTheNextSocketOnItsPort) {
  Bus bus{CanBusServerConfig{}};  // no thread: the test steps it
  CanBusServer& server = *bus.server;
  const int master = UdpNode(server.port());
  const int listener = UdpNode(server.port());
  SendMessage(master, Hello());
  SendMessage(listener, Hello());
  server.Step(0);
  ASSERT_EQ(server.node_count(), 2);
  (void)FramesWaiting(listener);  // the welcome
  const std::uint16_t port = PortOf(master);
  ::close(master);  // SIGKILL: no bye
  int ready[2];
  int release[2];
  ASSERT_EQ(::pipe(ready), 0);
  ASSERT_EQ(::pipe(release), 0);
  const bool as_nobody = ::geteuid() == 0;
  const pid_t child = ::fork();
  if (child == 0) {
    if (as_nobody && (::setgid(kNobody) != 0 || ::setuid(kNobody) != 0)) ::_exit(2);
    const int heir = UdpNode(server.port(), port);
    if (heir < 0) ::_exit(3);
    bus_datagram::Message frame{};
    frame.type = bus_datagram::Type::kFrame;
    frame.frame.id = 0x181;
    frame.frame.len = 8;
    SendMessage(heir, frame);
    bus_datagram::Message bus_off{};
    bus_off.type = bus_datagram::Type::kControl;
    bus_off.action = bus_datagram::Action::kBusOff;
    SendMessage(heir, bus_off);
    char c = 1;
    (void)::write(ready[1], &c, 1);
    (void)::read(release[0], &c, 1);  // keep the socket until the daemon has seen it
    ::_exit(0);
  }
  char c = 0;
  ASSERT_EQ(::read(ready[0], &c, 1), 1) << "the successor could not bind the freed port";
  std::this_thread::sleep_for(std::chrono::nanoseconds(CanBusServer::kOwnerCheckPeriod_ns + 1'000'000));
  for (int i = 0; i < 5; ++i) server.Step(1'000'000);
  (void)::write(release[1], &c, 1);
  int status = 0;
  ::waitpid(child, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the successor process failed";
  std::printf("successor %s: orphaned %llu, refused controls %llu, malformed %llu, nodes %d\n",
              as_nobody ? "nobody" : "own user", static_cast<unsigned long long>(server.orphaned_nodes()),
              static_cast<unsigned long long>(server.refused_controls()),
              static_cast<unsigned long long>(server.malformed_datagrams()), server.node_count());
  EXPECT_EQ(server.orphaned_nodes(), 1u) << "the dead node was detached";
  EXPECT_EQ(server.node_count(), 1) << "only the listener is attached";
  EXPECT_EQ(server.refused_controls(), 1u);
  EXPECT_FALSE(server.bus().is_bus_off(0)) << "the successor's bus-off acted";
  EXPECT_EQ(server.malformed_datagrams(), 1u) << "its frame came from no node";
  EXPECT_EQ(FramesWaiting(listener), 0) << "its frame went out on the bus";
  ::close(listener);
  for (int fd : {ready[0], ready[1], release[0], release[1]}) ::close(fd);
}

// A UDP node from which nothing arrives for node_timeout_ms is detached (it died, or its host did); one that sends
// stays attached.
TEST(CanBusAccess, ASilentNodeIsDetached) {
  CanBusServerConfig config;
  config.node_timeout_ms = 30;
  Bus bus{config};
  CanBusServer& server = *bus.server;
  const int quiet = UdpNode(server.port());
  const int talking = UdpNode(server.port());
  SendMessage(quiet, Hello());
  SendMessage(talking, Hello());
  server.Step(0);
  ASSERT_EQ(server.node_count(), 2);
  for (int i = 0; i < 8; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    SendMessage(talking, Hello());  // what UdpCanBusPort sends when it has sent nothing for kKeepAlive_ms
    server.Step(0);
  }
  EXPECT_EQ(server.silent_nodes(), 1u);
  EXPECT_EQ(server.node_count(), 1);
  ::close(quiet);
  ::close(talking);
}

// ---- Unix-domain mode -------------------------------------------------------------------------------------------

// A fresh directory others may enter (mode 0755: the socket file's own mode is then what decides), removed after.
struct TempDir {
  TempDir() { ::chmod(dir.path().c_str(), 0755); }
  std::string Socket() const { return dir.File("canbus.sock"); }
  teleop::test::ScopedTempDir dir{"canbus"};
};

CanBusServerConfig UnixConfig(const TempDir& dir, unsigned mode) {
  CanBusServerConfig config;
  config.bind_address = "unix:" + dir.Socket();
  config.socket_mode = mode;
  return config;
}

// As AttachAs, over the Unix socket, and when attached sends a bus-off command for node 0. Exit status: 0 attached
// (and sent), 1 no welcome, 3 refused by the socket file's permissions, 2 no setuid.
int AttachAndCommandAs(std::uint32_t uid, const std::string& address, Bus& bus) {
  const pid_t child = ::fork();
  if (child == 0) {
    if (::setgid(uid) != 0 || ::setuid(uid) != 0) ::_exit(2);
    try {
      UdpCanBusPort port_as_user(address, 0, 300.0);
      ::_exit(port_as_user.SendControl(bus_datagram::Action::kBusOff, 0) ? 0 : 4);
    } catch (const Error& e) {
      ::_exit(std::strstr(e.what(), "not allowed to join") != nullptr ? 3 : 1);
    }
  }
  bus.Start();
  int status = 0;
  ::waitpid(child, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

template <typename Done>
void WaitFor(Done done) {
  for (int i = 0; i < 400 && !done(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

TEST(CanBusAccessUnix, TheSocketFileHasTheConfiguredModeAndGroup) {
  TempDir dir;
  CanBusServerConfig config = UnixConfig(dir, 0660);
  const gid_t group = ::geteuid() == 0 ? 65534 : ::getegid();  // root may give any group; a user its own
  config.socket_gid = static_cast<int>(group);
  {
    Bus bus{config};
    struct stat st {};
    ASSERT_EQ(::lstat(dir.Socket().c_str(), &st), 0);
    EXPECT_TRUE(S_ISSOCK(st.st_mode));
    EXPECT_EQ(st.st_mode & 07777, 0660u);
    EXPECT_EQ(st.st_gid, group);
    EXPECT_EQ(st.st_uid, ::geteuid());
    EXPECT_EQ(bus.server->unix_path(), dir.Socket());
  }
  EXPECT_FALSE(std::filesystem::exists(dir.Socket())) << "the daemon removes its socket file when it stops";
}

TEST(CanBusAccessUnix, FramesGoBetweenNodesAndControlComesOnlyFromAController) {
  TempDir dir;
  CanBusServerConfig config = UnixConfig(dir, 0600);
  config.controller_uids = {static_cast<std::uint32_t>(::geteuid()) + 1};  // not us
  Bus bus{config};
  bus.Start();
  UdpCanBusPort a("unix:" + dir.Socket(), 0, 2000.0);
  UdpCanBusPort b("unix:" + dir.Socket(), 0, 2000.0);
  EXPECT_EQ(bus.server->node_count(), 2);
  EXPECT_NE(a.node(), b.node());
  proto::can::CanFrame frame{};
  frame.id = 0x123;
  frame.len = 2;
  frame.data[0] = 0xAB;
  frame.data[1] = 0xCD;
  ASSERT_EQ(a.Write(frame), CanWriteStatus::kOk);
  proto::can::CanFrame got{};
  bool received = false;
  WaitFor([&] { return received = b.Read(got); });
  ASSERT_TRUE(received) << "a frame sent by one node reaches the other";
  EXPECT_EQ(got.id, 0x123u);
  EXPECT_EQ(got.len, 2);
  EXPECT_EQ(got.data[1], 0xCD);
  EXPECT_GT(b.receive_time_ns(), 0);

  ASSERT_TRUE(a.SendControl(bus_datagram::Action::kBusOff, 0));
  ASSERT_TRUE(a.SendControl(bus_datagram::Action::kInjectErrors, 3));
  WaitFor([&] { return bus.server->refused_controls() >= 2; });
  EXPECT_EQ(bus.server->refused_controls(), 2u);
  EXPECT_FALSE(bus.server->bus().is_bus_off(0)) << "a refused command must not act";
  EXPECT_EQ(bus.server->refused_hellos(), 0u);
}

TEST(CanBusAccessUnix, TheDaemonsOwnUserIsTheController) {
  TempDir dir;
  Bus bus{UnixConfig(dir, 0600)};
  bus.Start();
  UdpCanBusPort a("unix:" + dir.Socket(), 0, 2000.0);
  ASSERT_TRUE(a.SendControl(bus_datagram::Action::kBusOff, 0));
  WaitFor([&] { return bus.server->bus().is_bus_off(0); });
  EXPECT_TRUE(bus.server->bus().is_bus_off(0));
  EXPECT_EQ(bus.server->refused_controls(), 0u);
}

TEST(CanBusAccessUnix, FilePermissionsRefuseAnotherUserBeforeTheDaemonSeesIt) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to run a process as another user";
  TempDir dir;
  CanBusServerConfig config = UnixConfig(dir, 0600);  // owner only ...
  config.allowed_uids = {0, kNobody};                 // ... though the daemon itself would admit nobody
  Bus bus{config};
  EXPECT_EQ(AttachAndCommandAs(kNobody, "unix:" + dir.Socket(), bus), 3) << "connect() must fail with EACCES";
  EXPECT_EQ(bus.server->refused_hellos(), 0u) << "nothing reached the daemon";
  EXPECT_EQ(bus.server->node_count(), 0);
  UdpCanBusPort own("unix:" + dir.Socket(), 0, 2000.0);
  EXPECT_EQ(bus.server->node_count(), 1);
}

TEST(CanBusAccessUnix, TheKernelsCredentialsRefuseAUserNotAllowed) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to run a process as another user";
  TempDir dir;
  Bus bus{UnixConfig(dir, 0666)};  // anyone may send: only the credentials stand in the way
  EXPECT_EQ(AttachAndCommandAs(kNobody, "unix:" + dir.Socket(), bus), 1) << "nobody attached";
  EXPECT_GE(bus.server->refused_hellos(), 1u);
  EXPECT_EQ(bus.server->node_count(), 0);
}

TEST(CanBusAccessUnix, AnAllowedUserAttachesButItsControlCommandIsRefused) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to run a process as another user";
  TempDir dir;
  CanBusServerConfig config = UnixConfig(dir, 0660);
  config.socket_gid = static_cast<int>(kNobody);  // nogroup: nobody may send through the file's group bits
  config.allowed_uids = {0, kNobody};             // controller: the daemon's own user only (default)
  Bus bus{config};
  EXPECT_EQ(AttachAndCommandAs(kNobody, "unix:" + dir.Socket(), bus), 0) << "nobody, allowed, attached";
  WaitFor([&] { return bus.server->refused_controls() >= 1; });
  EXPECT_EQ(bus.server->refused_controls(), 1u);
  EXPECT_FALSE(bus.server->bus().is_bus_off(0)) << "the non-controller's bus-off must not act";
  EXPECT_EQ(bus.server->refused_hellos(), 0u);
}

// Golden start-up behaviour at an existing path: a stale socket (its daemon was killed: the file stays, nothing is
// bound) is replaced; a live daemon's socket is refused and that daemon keeps working; a file that is not a socket
// is never removed.
TEST(CanBusAccessUnix, AStaleSocketIsReplacedALiveOneRefused) {
  TempDir dir;
  {
    const int stale = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, dir.Socket().c_str(), sizeof(addr.sun_path) - 1);
    ASSERT_EQ(::bind(stale, reinterpret_cast<const sockaddr*>(&addr), sizeof addr), 0);  // NOLINT: sockets API
    ::close(stale);                                                                      // as a killed daemon leaves it
    ASSERT_TRUE(std::filesystem::is_socket(dir.Socket()));
  }
  Bus live{UnixConfig(dir, 0600)};
  EXPECT_TRUE(live.server->replaced_stale_socket());
  live.Start();
  try {
    CanBusServer second(UnixConfig(dir, 0600));
    ADD_FAILURE() << "a second daemon took over a live bus";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("another teleop-canbus is running on " + dir.Socket()), std::string::npos)
        << e.what();
  }
  UdpCanBusPort node("unix:" + dir.Socket(), 0, 2000.0);  // the first daemon still answers
  EXPECT_EQ(live.server->node_count(), 1);

  TempDir other;
  { std::ofstream(other.Socket()) << "not a socket\n"; }
  try {
    CanBusServer refused(UnixConfig(other, 0600));
    ADD_FAILURE() << "a regular file at the socket path was replaced";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("exists and is not a socket"), std::string::npos) << e.what();
  }
  std::ifstream kept(other.Socket());
  std::string line;
  std::getline(kept, line);
  EXPECT_EQ(line, "not a socket");
}

// The receive path drains every queued datagram in one step without blocking, and counts each it refuses.
TEST(CanBusAccessUnix, OneStepDrainsTheQueueAndCountsRefusals) {
  TempDir dir;
  CanBusServerConfig config = UnixConfig(dir, 0600);
  config.controller_uids = {static_cast<std::uint32_t>(::geteuid()) + 1};  // not us
  Bus bus{config};                                                         // no thread: the test steps it
  const int s = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, dir.Socket().c_str(), sizeof(addr.sun_path) - 1);
  ASSERT_EQ(::connect(s, reinterpret_cast<const sockaddr*>(&addr), sizeof addr), 0);  // NOLINT: sockets API
  std::array<std::uint8_t, bus_datagram::kMaxSize> out{};
  bus_datagram::Message hello{};
  hello.type = bus_datagram::Type::kHello;
  bus_datagram::Message control{};
  control.type = bus_datagram::Type::kControl;
  control.action = bus_datagram::Action::kBusOff;
  const std::uint8_t junk[3] = {1, 2, 3};
  // Queued before the daemon has even accepted the connection: one step accepts and reads all of it.
  ASSERT_EQ(::send(s, out.data(), bus_datagram::Encode(hello, out), MSG_DONTWAIT), 5);
  for (int i = 0; i < 40; ++i) ASSERT_EQ(::send(s, junk, sizeof junk, MSG_DONTWAIT), 3);
  for (int i = 0; i < 20; ++i) ASSERT_GT(::send(s, out.data(), bus_datagram::Encode(control, out), MSG_DONTWAIT), 0);
  bus.server->Step(0);  // everything is queued: one step reads all of it and returns
  EXPECT_EQ(bus.server->node_count(), 1);
  EXPECT_EQ(bus.server->malformed_datagrams(), 40u);
  EXPECT_EQ(bus.server->refused_controls(), 20u);
  EXPECT_FALSE(bus.server->bus().is_bus_off(0));
  bus.server->Step(0);  // nothing queued: returns at once, nothing new counted
  EXPECT_EQ(bus.server->malformed_datagrams(), 40u);
  ::shutdown(s, SHUT_WR);  // the node goes away without a bye: the daemon drops it on the next step
  bus.server->Step(0);
  EXPECT_EQ(bus.server->node_count(), 0);
  std::array<std::uint8_t, 64> welcome{};
  EXPECT_EQ(::recv(s, welcome.data(), welcome.size(), MSG_DONTWAIT), 6) << "the hello was answered";
  ::close(s);
}

}  // namespace
}  // namespace teleop::transport
