#include "teleop/link/link_config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

// Asio trips -Wnull-dereference in its own inlined scheduler code (GCC 12, -O2); not ours to fix.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <boost/asio/ip/udp.hpp>
#pragma GCC diagnostic pop
#include <chrono>
#include <thread>

#include "teleop/error.hpp"
#include "transport/link_test_helpers.hpp"

namespace teleop::transport {
namespace {

using link::LinkConfig;
using link::MakeLink;
using proto::SenderRole;

// Two free ports, found by binding throw-away links (the kernel hands out distinct ephemeral ports).
std::pair<std::uint16_t, std::uint16_t> TwoFreePorts() {
  UdpLink a(UdpLinkConfig{});
  UdpLink b(UdpLinkConfig{});
  return {a.local_port(), b.local_port()};
}

TEST(MakeLink, UdpLinksTheTwoRolesTogether) {
  const auto [master_port, slave_port] = TwoFreePorts();
  LinkConfig master_config;
  master_config.udp.bind_port = master_port;
  master_config.udp.peer_port = slave_port;
  master_config.udp.expected_peer = SenderRole::kMaster;  // wrong on purpose: MakeLink derives it from the role
  LinkConfig slave_config;
  slave_config.udp.bind_port = slave_port;
  slave_config.udp.peer_port = master_port;
  const std::unique_ptr<Link> master = MakeLink(master_config, SenderRole::kMaster);
  const std::unique_ptr<Link> slave = MakeLink(slave_config, SenderRole::kSlave);
  EXPECT_THAT(master->Describe(), ::testing::StartsWith("udp 127.0.0.1:" + std::to_string(master_port)));
  EXPECT_THAT(master->Describe(), ::testing::HasSubstr("expects slave"));
  EXPECT_THAT(slave->Describe(), ::testing::HasSubstr("expects master"));

  ASSERT_TRUE(master->Send(test::MakeSample(SenderRole::kMaster, 1)));
  ASSERT_TRUE(slave->Send(test::MakeSample(SenderRole::kSlave, 1)));
  proto::SampleMessage got;
  bool master_got = false;
  bool slave_got = false;
  for (int i = 0; i < 200 && !(master_got && slave_got); ++i) {
    master_got = master_got || master->Poll(got);
    slave_got = slave_got || slave->Poll(got);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_TRUE(master_got);
  EXPECT_TRUE(slave_got);
}

TEST(MakeLink, UnknownTransportListsTheKnownOnes) {
  LinkConfig config;
  config.transport = "carrier-pigeon";
  try {
    (void)MakeLink(config, SenderRole::kMaster);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("'carrier-pigeon'"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("known transports: 'udp'"));
  }
}

TEST(MakeLink, RejectsAMissingPeerPortAndABadTimeout) {
  LinkConfig config;
  EXPECT_THROW((void)MakeLink(config, SenderRole::kMaster), Error);  // peer_port 0
  config.udp.peer_port = 47002;
  config.timeout_ms = 0.0;
  EXPECT_THROW((void)MakeLink(config, SenderRole::kMaster), Error);
  config.timeout_ms = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)MakeLink(config, SenderRole::kMaster), Error);
}

}  // namespace
}  // namespace teleop::transport
