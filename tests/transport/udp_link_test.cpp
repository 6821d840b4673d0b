// UdpLink on 127.0.0.1, two links in one process. On Linux a datagram sent on loopback is in the receiver's queue
// when send_to returns, so "send, then Poll once" is deterministic; Receive() still retries briefly (no speed
// assertion, only a guard against a hang).
#include "teleop/transport/udp_link.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

// Asio trips -Wnull-dereference in its own inlined scheduler code (GCC 12, -O2); not ours to fix.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/udp.hpp>
#pragma GCC diagnostic pop
#include <dirent.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <memory>
#include <thread>
#include <vector>

#include "teleop/error.hpp"
#include "test_utilities/kernel_arrival_stamps.hpp"
#include "test_utilities/limit_malloc.hpp"
#include "transport/link_test_helpers.hpp"

namespace teleop::transport {
namespace {

namespace asio = boost::asio;
using asio::ip::udp;
using proto::DecodeStatus;
using proto::SenderRole;
using test::MakeSample;

UdpLinkConfig Config(SenderRole expected_peer) {
  UdpLinkConfig c;
  c.bind_address = "127.0.0.1";
  c.bind_port = 0;
  c.expected_peer = expected_peer;
  return c;
}

// master <-> slave, on kernel-chosen ports.
struct Pair {
  Pair() : master(Config(SenderRole::kSlave)), slave(Config(SenderRole::kMaster)) {
    master.SetPeer("127.0.0.1", slave.local_port());
    slave.SetPeer("127.0.0.1", master.local_port());
  }
  UdpLink master;
  UdpLink slave;
};

bool Receive(Link& link, proto::SampleMessage& out) {
  for (int i = 0; i < 200; ++i) {
    if (link.Poll(out)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return false;
}

// Sends raw bytes from a socket of its own (to inject malformed datagrams).
struct RawSender {
  RawSender() : socket(io, udp::endpoint(asio::ip::make_address("127.0.0.1"), 0)) {}
  void Send(const std::vector<std::uint8_t>& bytes, std::uint16_t port) {
    socket.send_to(asio::buffer(bytes), udp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  }
  std::uint16_t port() const { return socket.local_endpoint().port(); }
  asio::io_context io;
  udp::socket socket;
};

std::vector<std::uint8_t> Encode(const proto::SampleMessage& m) {
  std::vector<std::uint8_t> b(proto::MaxEncodedSampleSize());
  b.resize(proto::EncodeSample(m, b));
  return b;
}

std::vector<std::uint8_t> FlipBits(std::vector<std::uint8_t> bytes, std::size_t index, std::uint8_t mask) {
  if (index < bytes.size()) bytes[index] = static_cast<std::uint8_t>(bytes[index] ^ mask);
  return bytes;
}

TEST(UdpLink, DeliversASampleBothWays) {
  Pair p;
  const proto::SampleMessage sent = MakeSample(SenderRole::kMaster, 41);
  ASSERT_TRUE(p.master.Send(sent));
  proto::SampleMessage got;
  ASSERT_TRUE(Receive(p.slave, got));
  EXPECT_EQ(got.sequence, 41u);
  EXPECT_EQ(got.sender, SenderRole::kMaster);
  EXPECT_EQ(got.dof, 3);
  EXPECT_DOUBLE_EQ(got.position_m[2], 0.041 + 0.2);
  EXPECT_EQ(got.force_N[1], 2.0);

  ASSERT_TRUE(p.slave.Send(MakeSample(SenderRole::kSlave, 7)));
  ASSERT_TRUE(Receive(p.master, got));
  EXPECT_EQ(got.sequence, 7u);
  EXPECT_EQ(p.master.counters().sent, 1u);
  EXPECT_EQ(p.slave.counters().sent, 1u);
  EXPECT_EQ(p.slave.counters().accepted, 1u);
  test::ExpectCountersBalance(p.slave.counters());
}

TEST(UdpLink, PollWithNothingPendingLeavesTheSampleAlone) {
  Pair p;
  proto::SampleMessage out = MakeSample(SenderRole::kSlave, 99);
  EXPECT_FALSE(p.master.Poll(out));
  EXPECT_EQ(out.sequence, 99u);
  EXPECT_EQ(p.master.counters().received, 0u);
}

TEST(UdpLink, NewestWinsWhenSeveralAreQueued) {
  Pair p;
  // Out of order on purpose: 1, 2, 5, 3, 4, 5. Newest is 5; 3 and 4 are late; the second 5 is a duplicate.
  for (std::uint32_t s : {1u, 2u, 5u, 3u, 4u, 5u}) ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kMaster, s)));
  proto::SampleMessage got;
  ASSERT_TRUE(Receive(p.slave, got));
  EXPECT_EQ(got.sequence, 5u);
  const LinkCounters& c = p.slave.counters();
  EXPECT_EQ(c.received, 6u);
  EXPECT_EQ(c.accepted, 1u);
  EXPECT_EQ(c.superseded, 2u);  // 1 and 2
  EXPECT_EQ(c.reordered, 2u);   // 3 and 4
  EXPECT_EQ(c.duplicates, 1u);
  EXPECT_EQ(c.lost, 0u);
  test::ExpectCountersBalance(c);
  // Nothing newer: the next Poll returns false.
  ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kMaster, 4)));
  EXPECT_FALSE(p.slave.Poll(got));
}

TEST(UdpLink, MalformedDatagramsAreCountedByReasonAndDoNotDisturbValidTraffic) {
  UdpLinkConfig config = Config(SenderRole::kMaster);
  config.accept_only_peer_address = false;  // the raw socket is not the configured peer
  UdpLink slave(config);
  UdpLink master(Config(SenderRole::kSlave));
  master.SetPeer("127.0.0.1", slave.local_port());
  RawSender raw;

  const std::vector<std::uint8_t> valid = Encode(MakeSample(SenderRole::kMaster, 10));
  ASSERT_EQ(valid.size(), 112u);
  const std::vector<std::uint8_t> bad_crc = FlipBits(valid, 50, 0x04);
  const std::vector<std::uint8_t> bad_magic = FlipBits(valid, 0, 0xFF);
  std::vector<std::uint8_t> too_long = valid;
  too_long.resize(1000, 0xAA);  // larger than the receive buffer: read truncated, still rejected
  proto::SampleMessage nan_sample = MakeSample(SenderRole::kMaster, 11);
  nan_sample.force_N[0] = std::numeric_limits<double>::quiet_NaN();
  proto::SampleMessage far = MakeSample(SenderRole::kMaster, 12);
  far.position_m[1] = 50.0;

  ASSERT_TRUE(master.Send(MakeSample(SenderRole::kMaster, 1)));
  raw.Send({}, slave.local_port());  // empty datagram
  raw.Send(std::vector<std::uint8_t>(valid.begin(), valid.begin() + 20), slave.local_port());
  raw.Send(bad_crc, slave.local_port());
  raw.Send(bad_magic, slave.local_port());
  raw.Send(too_long, slave.local_port());
  raw.Send(Encode(nan_sample), slave.local_port());
  raw.Send(Encode(far), slave.local_port());
  ASSERT_TRUE(master.Send(MakeSample(SenderRole::kMaster, 2)));

  proto::SampleMessage got;
  ASSERT_TRUE(Receive(slave, got));
  EXPECT_EQ(got.sequence, 2u);
  const LinkCounters& c = slave.counters();
  EXPECT_EQ(c.received, 9u);
  EXPECT_EQ(c.rejected, 7u);
  EXPECT_EQ(test::Rejected(c, DecodeStatus::kTooShort), 2u);
  EXPECT_EQ(test::Rejected(c, DecodeStatus::kBadCrc), 1u);
  EXPECT_EQ(test::Rejected(c, DecodeStatus::kBadMagic), 1u);
  EXPECT_EQ(test::Rejected(c, DecodeStatus::kBadLength), 1u);
  EXPECT_EQ(test::Rejected(c, DecodeStatus::kNonFinite), 1u);
  EXPECT_EQ(test::Rejected(c, DecodeStatus::kOutOfRange), 1u);
  EXPECT_EQ(c.accepted, 1u);
  EXPECT_EQ(c.superseded, 1u);
  EXPECT_EQ(c.lost, 0u);  // rejected datagrams never reach the sequence tracker
  test::ExpectCountersBalance(c);
}

TEST(UdpLink, DatagramsFromAnotherAddressNeverReachTheLink) {
  Pair p;  // accept_only_peer_address = true: the socket is connect()ed to the peer
  EXPECT_TRUE(p.slave.connected());
  EXPECT_THAT(p.slave.Describe(), ::testing::HasSubstr("connected"));
  RawSender raw;
  for (int i = 0; i < 50; ++i) {  // valid, but not from the peer: the kernel drops them before the queue
    raw.Send(Encode(MakeSample(SenderRole::kMaster, 100 + i)), p.slave.local_port());
  }
  ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kMaster, 1)));
  proto::SampleMessage got;
  ASSERT_TRUE(Receive(p.slave, got));
  EXPECT_EQ(got.sequence, 1u);
  EXPECT_EQ(p.slave.counters().received, 1u) << "only the peer's datagram was read";
  EXPECT_EQ(p.slave.counters().wrong_sender, 0u);
  EXPECT_EQ(p.slave.counters().rejected, 0u);
  test::ExpectCountersBalance(p.slave.counters());
}

TEST(UdpLink, WrongRoleIsRejected) {
  Pair p;
  // The master process mislabelled as slave (e.g. two slaves configured against each other).
  ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kSlave, 1)));
  ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kSlave, 2)));
  proto::SampleMessage got;
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_FALSE(p.slave.Poll(got));
  EXPECT_EQ(p.slave.counters().received, 2u);
  EXPECT_EQ(p.slave.counters().wrong_sender, 2u);
  EXPECT_EQ(p.slave.counters().accepted, 0u);
  test::ExpectCountersBalance(p.slave.counters());
}

TEST(UdpLink, SendAndPollDoNotAllocate) {
  Pair p;
  proto::SampleMessage got;
  // Warm-up: first use of the socket and of the CRC table.
  ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kMaster, 1)));
  ASSERT_TRUE(Receive(p.slave, got));
  std::uint64_t allocations = 0;
  int received = 0;
  {
    teleop::test::AllocationCounter counter;
    for (std::uint32_t s = 2; s < 200; ++s) {
      const proto::SampleMessage m = MakeSample(SenderRole::kMaster, s);
      if (!p.master.Send(m)) break;
      if (p.slave.Poll(got)) ++received;
      (void)p.slave.Poll(got);  // an empty drain too
    }
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_GT(received, 150);
}

TEST(UdpLink, BindFailureNamesTheAddress) {
  UdpLink first(Config(SenderRole::kSlave));
  UdpLinkConfig clash = Config(SenderRole::kSlave);
  clash.bind_port = first.local_port();
  try {
    UdpLink second(clash);
    FAIL() << "bind to a port in use succeeded";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("127.0.0.1:" + std::to_string(first.local_port())));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("cannot bind"));
  }
}

TEST(UdpLink, BadAddressesAreSetUpErrors) {
  UdpLinkConfig c = Config(SenderRole::kSlave);
  c.bind_address = "master.local";
  EXPECT_THROW(
      {
        try {
          UdpLink link(c);
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), ::testing::HasSubstr("'master.local'"));
          throw;
        }
      },
      Error);
  c = Config(SenderRole::kSlave);
  c.bind_address = "192.0.2.1";  // TEST-NET-1: not an address of this host
  EXPECT_THROW(UdpLink link(c), Error);
  c = Config(SenderRole::kSlave);
  c.peer_address = "::1";  // IPv6 peer for an IPv4 socket
  c.peer_port = 5000;
  EXPECT_THROW(UdpLink link(c), Error);
  c = Config(SenderRole::kSlave);
  c.receive_buffer_bytes = -1;
  EXPECT_THROW(UdpLink link(c), Error);
}

TEST(UdpLink, SendWithoutPeerIsACountedError) {
  UdpLink link(Config(SenderRole::kSlave));
  EXPECT_FALSE(link.Send(MakeSample(SenderRole::kMaster, 1)));
  proto::SampleMessage bad = MakeSample(SenderRole::kMaster, 1);
  bad.dof = 13;  // kMaxWireDof + 1
  link.SetPeer("127.0.0.1", 9);
  EXPECT_FALSE(link.Send(bad));  // not encodable
  EXPECT_EQ(link.counters().send_errors, 2u);
  EXPECT_EQ(link.counters().sent, 0u);
}

TEST(UdpLink, DescribeShowsBothEnds) {
  Pair p;
  const std::string text = p.master.Describe();
  EXPECT_THAT(text, ::testing::StartsWith("udp 127.0.0.1:" + std::to_string(p.master.local_port()) +
                                          " -> 127.0.0.1:" + std::to_string(p.slave.local_port())));
  EXPECT_THAT(text, ::testing::HasSubstr("expects slave"));
}

// SO_RCVBUF of this process's IPv4 UDP socket bound to `port`, found through /proc/self/fd (the link does not
// expose its socket); -1 if there is none.
int ReceiveBufferOfSocketOnPort(std::uint16_t port) {
  DIR* dir = opendir("/proc/self/fd");
  if (dir == nullptr) return -1;
  int found = -1;
  while (const dirent* entry = readdir(dir)) {
    const int fd = std::atoi(entry->d_name);
    if (fd <= 2) continue;
    sockaddr_in address{};
    socklen_t length = sizeof address;
    int type = 0;
    socklen_t type_length = sizeof type;
    // NOLINTNEXTLINE(cppcoreguidelines-pro-type-reinterpret-cast): the sockets API takes a sockaddr*.
    if (getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0 || address.sin_family != AF_INET ||
        getsockopt(fd, SOL_SOCKET, SO_TYPE, &type, &type_length) != 0 || type != SOCK_DGRAM ||
        ntohs(address.sin_port) != port) {
      continue;
    }
    int bytes = 0;
    socklen_t bytes_length = sizeof bytes;
    if (getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &bytes, &bytes_length) == 0) found = bytes;
    break;
  }
  closedir(dir);
  return found;
}

long ReadProcNumber(const char* path) {
  std::ifstream in(path);
  long value = -1;
  in >> value;
  return value;
}

// The size reaches the socket: read back with getsockopt. Linux stores twice the requested size (socket(7): the
// kernel doubles it for its bookkeeping overhead), capped at net.core.rmem_max; 0 leaves the kernel default
// (net.core.rmem_default).
TEST(UdpLink, ReceiveBufferCanBeSized) {
  const long rmem_max = ReadProcNumber("/proc/sys/net/core/rmem_max");
  const long rmem_default = ReadProcNumber("/proc/sys/net/core/rmem_default");
  ASSERT_GT(rmem_max, 0);
  ASSERT_GT(rmem_default, 0);
  for (const int requested : {1 << 15, 1 << 17}) {
    UdpLinkConfig c = Config(SenderRole::kSlave);
    c.receive_buffer_bytes = requested;
    UdpLink link(c);
    const long expected = 2 * std::min<long>(requested, rmem_max);
    EXPECT_EQ(ReceiveBufferOfSocketOnPort(link.local_port()), expected) << "requested " << requested;
  }
  // 0: the link asks for 4 MiB (SO_RCVBUFFORCE with CAP_NET_ADMIN, else capped at rmem_max) and reports what it got.
  UdpLink by_default(Config(SenderRole::kSlave));
  const int got = ReceiveBufferOfSocketOnPort(by_default.local_port());
  EXPECT_EQ(by_default.receive_buffer_bytes(), got);
  const long asked = 4L << 20;
  EXPECT_TRUE(got == 2 * asked || got == 2 * std::min(asked, rmem_max)) << got;
  EXPECT_GE(got, std::min<long>(rmem_default, 2 * asked));
  EXPECT_THAT(by_default.Describe(), ::testing::HasSubstr("rcvbuf " + std::to_string(got) + " B"));
}

std::int64_t MonotonicNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Slack for the realtime → monotonic conversion (the offset is read at the Poll, the stamp taken at arrival; NTP
// slewing moves the offset by ≤ 500 ppm): 50 µs, far below the 2 ms the tests wait between arrival and Poll.
constexpr std::int64_t kClockSlackNs = 50'000;

TEST(UdpLinkReceiveTime, IsTheKernelArrivalTimeNotThePollTime) {
  const teleop::test::KernelArrivalStamps stamps;
  ASSERT_TRUE(stamps.active()) << "the kernel never stamped a datagram on arrival";
  Pair p;
  EXPECT_EQ(p.slave.newest_receive_time_ns(), 0) << "nothing received yet";
  const std::int64_t before_send = MonotonicNs();
  ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kMaster, 1)));
  // Wait until the datagram is in the socket (on loopback it normally is when send returns), then poll 2 ms later.
  ASSERT_TRUE(p.slave.WaitReadable(MonotonicNs() + 1'000'000'000));
  const std::int64_t readable = MonotonicNs();
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  const std::int64_t before_poll = MonotonicNs();
  proto::SampleMessage got;
  ASSERT_TRUE(p.slave.Poll(got));
  const std::int64_t after_poll = MonotonicNs();
  const std::int64_t received = p.slave.newest_receive_time_ns();
  EXPECT_TRUE(p.slave.newest_receive_time_from_kernel());
  EXPECT_GE(received, before_send - kClockSlackNs);
  EXPECT_LE(received, readable + kClockSlackNs) << "a poll-time stamp would be >= " << before_poll;
  EXPECT_LT(received, before_poll) << "the datagram was in the socket 2 ms before the Poll";
  EXPECT_LE(received, after_poll) << "never later than the Poll";
}

TEST(UdpLinkReceiveTime, BelongsToTheNewestAcceptedSampleOfTheDrain) {
  const teleop::test::KernelArrivalStamps stamps;
  ASSERT_TRUE(stamps.active()) << "the kernel never stamped a datagram on arrival";
  Pair p;
  ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kMaster, 1)));
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  const std::int64_t before_newest = MonotonicNs();
  ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kMaster, 3)));
  const std::int64_t after_newest = MonotonicNs();
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kMaster, 2)));  // late: counted, not applied, not its time
  proto::SampleMessage got;
  ASSERT_TRUE(p.slave.Poll(got));
  EXPECT_EQ(got.sequence, 3u);
  EXPECT_GE(p.slave.newest_receive_time_ns(), before_newest - kClockSlackNs);
  EXPECT_LE(p.slave.newest_receive_time_ns(), after_newest + kClockSlackNs);
  // An empty or stale-only drain keeps the time of the sample it still refers to.
  const std::int64_t kept = p.slave.newest_receive_time_ns();
  ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kMaster, 2)));
  EXPECT_FALSE(p.slave.Poll(got));
  EXPECT_EQ(p.slave.newest_receive_time_ns(), kept);
}

TEST(UdpLinkReceiveTime, IsMonotoneAcrossSamplesAndNotLaterThanEachPoll) {
  const teleop::test::KernelArrivalStamps stamps;
  ASSERT_TRUE(stamps.active()) << "the kernel never stamped a datagram on arrival";
  Pair p;
  proto::SampleMessage got;
  std::int64_t previous = 0;
  for (std::uint32_t s = 1; s <= 50; ++s) {
    ASSERT_TRUE(p.master.Send(MakeSample(SenderRole::kMaster, s)));
    ASSERT_TRUE(Receive(p.slave, got));
    const std::int64_t polled = MonotonicNs();
    const std::int64_t received = p.slave.newest_receive_time_ns();
    EXPECT_TRUE(p.slave.newest_receive_time_from_kernel());
    EXPECT_GT(received, previous) << "sample " << s;
    EXPECT_LE(received, polled) << "sample " << s;
    previous = received;
  }
}

TEST(UdpLinkReceiveOptions, PollUntilSpinsForADueSampleAndGivesUpAtTheDeadline) {
  Pair p;
  proto::SampleMessage got;
  const std::int64_t deadline = MonotonicNs() + 1'000'000;
  EXPECT_FALSE(p.slave.PollUntil(got, deadline));
  EXPECT_GE(MonotonicNs(), deadline) << "returns only once the deadline has passed";
  std::thread sender([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    (void)p.master.Send(MakeSample(SenderRole::kMaster, 1));
  });
  const bool arrived = p.slave.PollUntil(got, MonotonicNs() + 2'000'000'000);  // bound: a hang guard only
  sender.join();
  EXPECT_TRUE(arrived);
  EXPECT_EQ(got.sequence, 1u);
}

TEST(UdpLinkReceiveOptions, SpinPollAndBusyPollAreSelectableInTheConfig) {
  UdpLinkConfig config = Config(SenderRole::kMaster);
  config.spin_poll_us = 1000;
  config.busy_poll_us = 50;
  UdpLink slave(config);
  UdpLink master(Config(SenderRole::kSlave));
  master.SetPeer("127.0.0.1", slave.local_port());
  slave.SetPeer("127.0.0.1", master.local_port());
  // SO_BUSY_POLL is applied where permitted (CAP_NET_ADMIN above net.core.busy_read); either way the link works.
  SCOPED_TRACE(slave.busy_poll_applied() ? "busy poll applied" : "busy poll refused");
  EXPECT_THAT(
      slave.Describe(),
      ::testing::HasSubstr(slave.busy_poll_applied() ? "busy poll 50 us)" : "busy poll 50 us REFUSED by the kernel)"));
  EXPECT_THAT(master.Describe(), ::testing::Not(::testing::HasSubstr("busy poll")));
  proto::SampleMessage got;
  const std::int64_t start = MonotonicNs();
  EXPECT_FALSE(slave.Poll(got));
  EXPECT_GE(MonotonicNs() - start, 1'000'000) << "an empty Poll spins for spin_poll_us";
  ASSERT_TRUE(master.Send(MakeSample(SenderRole::kMaster, 1)));
  EXPECT_TRUE(slave.Poll(got));
  EXPECT_EQ(got.sequence, 1u);
  config.spin_poll_us = -1;
  EXPECT_THROW(UdpLink{config}, Error);
  config.spin_poll_us = 0;
  config.busy_poll_us = -1;
  EXPECT_THROW(UdpLink{config}, Error);
}

}  // namespace
}  // namespace teleop::transport
