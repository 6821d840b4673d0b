// The emulated bus between processes: teleop-canbus's core (CanBusServer) in a thread, nodes attached over UDP on
// 127.0.0.1 exactly as two processes would be. Checks delivery, ID order and frame-time pacing, fault injection
// through control datagrams, malformed datagrams, and the clear error when no daemon runs.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "can_test_helpers.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/can_bus_server.hpp"
#include "teleop/transport/can_link.hpp"
#include "teleop/transport/can_udp_bus_port.hpp"

namespace teleop::transport {
namespace {

using Clock = std::chrono::steady_clock;

/// teleop-canbus's core on its own thread, on a free port.
struct ServerThread {
  explicit ServerThread(double bitrate_bit_per_s = 1e6) {
    CanBusServerConfig config;
    config.port = 0;
    config.bus.nominal_bitrate_bit_per_s = bitrate_bit_per_s;
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
  for (std::uint32_t s = 0; s < 50; ++s) {
    ASSERT_TRUE(master.Send(test::MakeSample(proto::SenderRole::kMaster, 3, s)));
    ASSERT_TRUE(slave.Send(test::MakeSample(proto::SenderRole::kSlave, 3, s)));
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    if (slave.Poll(out)) {
      ++slave_got;
      EXPECT_TRUE(test::ConsistentSample(out));
    }
    if (master.Poll(out)) {
      ++master_got;
      EXPECT_TRUE(test::ConsistentSample(out));
    }
  }
  EXPECT_GE(slave_got, 40);  // loopback UDP on a loaded machine: a few polls may find nothing new yet
  EXPECT_GE(master_got, 40);
  EXPECT_EQ(slave.counters().rejected, 0u);
  EXPECT_EQ(master.counters().rejected, 0u);
}

TEST_F(UdpBusTest, ControlDatagramsInjectErrorsAndBusOff) {
  auto a = Attach();
  auto b = Attach();
  const int a_node = a->node();
  proto::can::CanWireFormat format{};
  format.dof = 1;
  CanLink master(format, proto::SenderRole::kMaster, std::move(a));
  ASSERT_TRUE(b->SendControl(bus_datagram::Action::kInjectErrors, 1));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
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
