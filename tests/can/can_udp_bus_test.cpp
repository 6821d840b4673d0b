// The emulated bus between processes: teleop-canbus's core (CanBusServer) in a thread, nodes attached over UDP on
// 127.0.0.1 exactly as two processes would be. Checks delivery, ID order and frame-time pacing, fault injection
// through control datagrams, malformed datagrams, and the clear error when no daemon runs.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "can_test_helpers.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/can_bus_server.hpp"
#include "teleop/transport/can_link.hpp"
#include "teleop/transport/can_log.hpp"
#include "teleop/transport/can_udp_bus_port.hpp"

namespace teleop::transport {
namespace {

using Clock = std::chrono::steady_clock;

/// teleop-canbus's core on its own thread, on a free port.
struct ServerThread {
  explicit ServerThread(double bitrate_bit_per_s = 1e6, std::string candump_log = "") {
    CanBusServerConfig config;
    config.port = 0;
    config.bus.nominal_bitrate_bit_per_s = bitrate_bit_per_s;
    config.candump_log_path = std::move(candump_log);
    server = std::make_unique<CanBusServer>(config);
    thread = std::thread([this] { server->Run(stop); });
  }
  ~ServerThread() {
    stop = true;
    thread.join();
  }
  std::unique_ptr<UdpCanBusPort> Attach() const {
    return std::make_unique<UdpCanBusPort>("127.0.0.1", server->port(), 2000);
  }
  std::unique_ptr<CanBusServer> server;
  std::atomic<bool> stop{false};
  std::thread thread;
};

class UdpBusTest : public ::testing::Test {
 protected:
  std::unique_ptr<UdpCanBusPort> Attach() { return bus_.Attach(); }
  ServerThread bus_;
  CanBusServer* server_ = bus_.server.get();
};

/// Reads until `n` frames arrived or `timeout` passed.
std::vector<std::pair<proto::can::CanFrame, Clock::time_point>> ReadFrames(
    CanPort& port, std::size_t n, std::chrono::milliseconds timeout = std::chrono::milliseconds(2000)) {
  std::vector<std::pair<proto::can::CanFrame, Clock::time_point>> out;
  const auto deadline = Clock::now() + timeout;
  proto::can::CanFrame f{};
  while (out.size() < n && Clock::now() < deadline) {
    if (port.Read(f)) {
      out.emplace_back(f, Clock::now());
    } else {
      std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
  }
  return out;
}

TEST(UdpBus, DeliversInIdOrderPacedByFrameTime) {
  const ServerThread bus(125'000.0);  // 1.08 ms per 8-byte frame: the burst is queued long before the first ends
  auto a = bus.Attach();
  auto b = bus.Attach();
  EXPECT_NE(a->node(), b->node());
  // A burst with descending identifiers: the first one goes on the wire at once, the rest in ID order.
  const std::vector<std::uint32_t> ids{0x300, 0x200, 0x180, 0x120, 0x110, 0x100};
  const auto first_write = Clock::now();
  for (const std::uint32_t id : ids) {
    proto::can::CanFrame f{};
    f.id = id;
    f.len = 8;
    ASSERT_EQ(a->Write(f), CanWriteStatus::kOk);
  }
  const auto got = ReadFrames(*b, ids.size());
  ASSERT_EQ(got.size(), ids.size());
  // The rest reached the daemon while the first frame was on the wire: lowest identifier first.
  for (std::size_t i = 2; i < got.size(); ++i) EXPECT_LT(got[i - 1].first.id, got[i].first.id) << i;
  EXPECT_EQ(got.front().first.id, 0x300u);
  // Pacing is a lower bound the daemon cannot beat: the last of 6 frames of 135 bits at 125 kbit/s ends no sooner
  // than 6 frame times after the first write. Measured from the write, not from the reader's first arrival, so a
  // reader that is scheduled late (a loaded machine) can only make the span longer, never shorter.
  const double span_s = std::chrono::duration<double>(got.back().second - first_write).count();
  EXPECT_GE(span_s, 6 * 135 / 125e3 * 0.95);
  EXPECT_TRUE(ReadFrames(*a, 1, std::chrono::milliseconds(50)).empty());  // never echoed to the sender
}

TEST_F(UdpBusTest, TwoLinksExchangeSamples) {
  proto::can::CanWireFormat format{};
  format.dof = 3;
  CanLink master(format, proto::SenderRole::kMaster, Attach());
  CanLink slave(format, proto::SenderRole::kSlave, Attach());
  proto::SampleMessage out{};
  int slave_got = 0, master_got = 0;
  // Each cycle waits on both ends until each has the other's whole cycle, or 2 s passed (a loaded machine), so every
  // cycle must arrive, intact and in order. Each end waits for a complete cycle (WaitReadable, at most 1 ms at a
  // time, as in a 1 kHz loop) before it polls: a CanLink drops a partial cycle untouched for
  // CycleAssembler::kExpiryTicks polls, and a daemon starved for that many milliseconds between a cycle's two frames
  // made blind 1 ms polls drop it (1 run in about 4 of the whole suite on 2 busy cores).
  const auto wait_ms = [] {
    const auto until = Clock::now() + std::chrono::milliseconds(1);
    return std::chrono::duration_cast<std::chrono::nanoseconds>(until.time_since_epoch()).count();
  };
  for (std::uint32_t s = 0; s < 50; ++s) {
    ASSERT_TRUE(master.Send(test::MakeSample(proto::SenderRole::kMaster, 3, s)));
    ASSERT_TRUE(slave.Send(test::MakeSample(proto::SenderRole::kSlave, 3, s)));
    bool at_slave = false, at_master = false;
    const auto deadline = Clock::now() + std::chrono::seconds(2);
    while (!(at_slave && at_master) && Clock::now() < deadline) {
      if (!at_slave && slave.WaitReadable(wait_ms()) && slave.Poll(out)) {
        EXPECT_TRUE(test::ConsistentSample(out));
        at_slave = out.sequence == s;
        slave_got += at_slave ? 1 : 0;
      }
      if (!at_master && master.WaitReadable(wait_ms()) && master.Poll(out)) {
        EXPECT_TRUE(test::ConsistentSample(out));
        at_master = out.sequence == s;
        master_got += at_master ? 1 : 0;
      }
    }
  }
  EXPECT_EQ(slave_got, 50);
  EXPECT_EQ(master_got, 50);
  EXPECT_EQ(slave.counters().rejected, 0u);
  EXPECT_EQ(master.counters().rejected, 0u);
  EXPECT_EQ(slave.counters().lost, 0u);
  EXPECT_EQ(master.counters().accepted, 50u);
}

// The trigger of a triggered slave on the daemon's port (ppoll on the node's socket, docs/can.md "Phase-locked
// cycles over CAN"): it fires once the master's whole cycle (4 frames at 6 DOF) has come, and the sample carries the
// kernel's receive time of its last frame, which the daemon sends no earlier than the end of its transmission.
TEST_F(UdpBusTest, TriggerWaitsOnTheSocketForTheWholeCycle) {
  proto::can::CanWireFormat format{};
  format.dof = 6;
  CanLink master(format, proto::SenderRole::kMaster, Attach());
  CanLink slave(format, proto::SenderRole::kSlave, Attach());
  const auto monotonic_ns = [] {
    timespec now{};
    clock_gettime(CLOCK_MONOTONIC, &now);
    return static_cast<std::int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
  };
  const std::int64_t sent_ns = monotonic_ns();
  ASSERT_TRUE(master.Send(test::MakeSample(proto::SenderRole::kMaster, 6, 9)));
  ASSERT_TRUE(slave.WaitReadable(sent_ns + 5'000'000'000)) << "the whole cycle arrived within 5 s";
  proto::SampleMessage out{};
  ASSERT_TRUE(slave.Poll(out));
  EXPECT_EQ(out.sequence, 9u);
  EXPECT_TRUE(test::ConsistentSample(out));
  EXPECT_EQ(slave.can_counters().frames_received, 4u) << "all four frames were read before it fired";
  // 4 frames of 8 bytes: 540 µs on a 1 Mbit/s bus before the last one ends (a lower bound: the daemon paces them).
  EXPECT_GE(slave.newest_receive_time_ns() - sent_ns, 500'000);
  EXPECT_LE(slave.newest_receive_time_ns(), monotonic_ns());
  // Nothing more comes: the wait ends at its deadline with false.
  EXPECT_FALSE(slave.WaitReadable(monotonic_ns() + 20'000'000));
  EXPECT_FALSE(slave.Poll(out));
}

TEST_F(UdpBusTest, PortFiltersAsSocketCanDoes) {
  auto a = Attach();
  CanReceiveOptions options;
  options.filters = {CanFilter::Exact(0x181), CanFilter::Masked(0x700, 0x780)};
  auto b = std::make_unique<UdpCanBusPort>("127.0.0.1", server_->port(), 2000, options);
  for (const std::uint32_t id : {0x180u, 0x181u, 0x182u, 0x701u, 0x77Fu, 0x601u}) {
    proto::can::CanFrame f{};
    f.id = id;
    f.len = 1;
    ASSERT_EQ(a->Write(f), CanWriteStatus::kOk);
  }
  proto::can::CanFrame fd{};
  fd.id = 0x181;
  fd.fd = true;
  fd.len = 12;
  ASSERT_EQ(a->Write(fd), CanWriteStatus::kOk);  // a's options pass FD; b's do not
  EXPECT_EQ(b->Write(fd), CanWriteStatus::kError);
  const auto got = ReadFrames(*b, 3);
  ASSERT_EQ(got.size(), 3u);
  std::vector<std::uint32_t> ids;
  for (const auto& g : got) ids.push_back(g.first.id);
  std::sort(ids.begin(), ids.end());  // the bus carries them in arbitration order, not in write order
  EXPECT_EQ(ids, (std::vector<std::uint32_t>{0x181, 0x701, 0x77F}));
  EXPECT_TRUE(ReadFrames(*b, 1, std::chrono::milliseconds(50)).empty());  // nothing else: the rest was filtered
}

TEST_F(UdpBusTest, ControlDatagramsInjectErrorsAndBusOff) {
  auto a = Attach();
  auto b = Attach();
  const int a_node = a->node();
  UdpCanBusPort* a_port = a.get();
  proto::can::CanWireFormat format{};
  format.dof = 1;
  CanLink master(format, proto::SenderRole::kMaster, std::move(a));
  // The control datagram and the frame leave the same socket, so the daemon handles them in that order: no sleep.
  ASSERT_TRUE(a_port->SendControl(bus_datagram::Action::kInjectErrors, 1));
  ASSERT_TRUE(master.Send(test::MakeSample(proto::SenderRole::kMaster, 1, 0)));
  const auto frames = ReadFrames(*b, 2);  // error frame, then the retransmitted frame
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_TRUE(frames[0].first.error);
  EXPECT_FALSE(frames[1].first.error);

  ASSERT_TRUE(b->SendControl(bus_datagram::Action::kBusOff, static_cast<std::uint32_t>(a_node)));
  proto::SampleMessage out{};
  const auto deadline = Clock::now() + std::chrono::seconds(2);
  while (!master.bus_off() && Clock::now() < deadline) {
    (void)master.Poll(out);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_TRUE(master.bus_off());
  EXPECT_FALSE(master.Send(test::MakeSample(proto::SenderRole::kMaster, 1, 1)));
  EXPECT_GE(master.counters().bus_errors, 2u);
}

TEST_F(UdpBusTest, MalformedDatagramsAreCountedNotFatal) {
  const int s = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(s, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(server_->port());
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const std::vector<std::vector<std::uint8_t>> junk{
      {}, {1, 2, 3}, {0x54, 0x43, 0x42, 0x31, 3, 0, 0, 1, 0, 0, 9}, {0x54, 0x43, 0x42, 0x31, 77}};
  for (const auto& d : junk) {
    ::sendto(s, d.data(), d.size(), 0, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));  // NOLINT
  }
  ::close(s);
  auto a = Attach();  // the daemon still works
  const auto deadline = Clock::now() + std::chrono::seconds(2);
  while (server_->malformed_datagrams() < junk.size() && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_EQ(server_->malformed_datagrams(), junk.size());
}

TEST(UdpBus, DaemonWritesACandumpLog) {
  const std::string path = ::testing::TempDir() + "teleop_canbus_candump.log";
  {
    const ServerThread bus(1e6, path);
    auto a = bus.Attach();
    auto b = bus.Attach();
    proto::can::CanFrame f{};
    f.id = 0x601;
    f.len = 8;
    f.data = {0x40, 0x41, 0x60, 0x00};
    ASSERT_EQ(a->Write(f), CanWriteStatus::kOk);
    proto::can::CanFrame g{};
    g.id = 0x1ABCDE0;
    g.extended = true;
    g.len = 2;
    g.data = {0xBE, 0xEF};
    ASSERT_EQ(b->Write(g), CanWriteStatus::kOk);
    ASSERT_EQ(ReadFrames(*b, 1).size(), 1u);
    ASSERT_EQ(ReadFrames(*a, 1).size(), 1u);
    const auto deadline = Clock::now() + std::chrono::seconds(2);
    while (bus.server->logged_frames() < 2 && Clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    EXPECT_EQ(bus.server->logged_frames(), 2u);
  }
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 2u);
  proto::can::CanFrame f{};
  std::uint64_t t = 0;
  std::string iface;
  for (const std::string& line : lines) {
    ASSERT_TRUE(ParseCandumpLine(line, f, t, iface)) << line;
    EXPECT_EQ(iface, "emcan0");
    EXPECT_GT(t, 1'600'000'000ULL * 1'000'000'000ULL);  // wall clock, as candump stamps
  }
  EXPECT_NE(lines[0].find(" emcan0 601#4041600000000000"), std::string::npos) << lines[0];
  EXPECT_NE(lines[1].find(" emcan0 01ABCDE0#BEEF"), std::string::npos) << lines[1];
}

TEST(UdpBusPort, NoDaemonGivesAClearError) {
  CanLinkConfig config;
  config.dof = 3;
  config.medium = CanMedium::kEmulatedBus;
  config.emulated_bus_port = 9;  // discard port: nothing answers
  config.connect_timeout_ms = 100;
  try {
    (void)MakeCanLink(config, proto::SenderRole::kMaster, 1000.0);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("teleop-canbus"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace teleop::transport
