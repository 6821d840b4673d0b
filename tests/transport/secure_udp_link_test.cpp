// UdpLink in authenticated mode (link.security.mode psk, docs/security.md): the handshake the master drives, sealed
// samples both ways, every other datagram counted by reason, session_epoch() on each new session, a peer restart,
// the key file checks, and no allocation in the steady-state cycle.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

// Asio trips -Wnull-dereference in its own inlined scheduler code (GCC 12, -O2); not ours to fix.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wnull-dereference"
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/udp.hpp>
#pragma GCC diagnostic pop
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "teleop/error.hpp"
#include "teleop/link/link_config.hpp"
#include "teleop/proto/codec.hpp"
#include "teleop/transport/secure_key_file.hpp"
#include "teleop/transport/udp_link.hpp"
#include "test_utilities/limit_malloc.hpp"
#include "test_utilities/temp_dir.hpp"
#include "transport/link_test_helpers.hpp"

namespace teleop::transport {
namespace {

namespace asio = boost::asio;
using asio::ip::udp;
using link::LinkConfig;
using link::MakeLink;
using proto::SenderRole;
using test::MakeSample;

// A directory with one fresh key file, removed afterwards.
struct KeyDir {
  KeyDir() { WriteNewKeyFile(key); }
  teleop::test::ScopedTempDir dir{"secure-link"};
  std::string key = dir.File("teleop.key");
};

UdpLinkConfig SecureConfig(SenderRole expected_peer, const std::string& key, int dof = 3) {
  UdpLinkConfig c;
  c.bind_address = "127.0.0.1";
  c.bind_port = 0;
  c.expected_peer = expected_peer;
  c.security.mode = LinkSecurityMode::kPsk;
  c.security.key_file = key;
  c.security.session.dof = dof;
  c.security.session.max_speed_m_per_s = 10.0;
  c.security.handshake_retry_ms = 20.0;
  c.peer_silence_ms = 200.0;
  return c;
}

std::uint64_t Secure(const LinkCounters& c, SecureReceiveStatus s) {
  return c.secure_rejected_by_reason[static_cast<std::size_t>(s)];
}

// Polls both links (the master's Poll drives the handshake) until both have a session, or gives up (no speed
// assertion: a guard against a hang only).
bool Establish(UdpLink& master, UdpLink& slave) {
  proto::SampleMessage got;
  for (int i = 0; i < 500; ++i) {
    (void)master.Poll(got);
    (void)slave.Poll(got);
    if (master.session_epoch() > 0 && slave.session_epoch() > 0) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return false;
}

// Sends from the master until the slave has a sample (the slave's session starts with the first frame or the
// confirm), returning it.
bool Deliver(UdpLink& from, UdpLink& to, SenderRole role, std::uint32_t& sequence, proto::SampleMessage& got) {
  for (int i = 0; i < 200; ++i) {
    (void)from.Send(MakeSample(role, sequence++));
    if (to.Poll(got)) return true;
    proto::SampleMessage ignored;
    (void)from.Poll(ignored);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return false;
}

struct SecurePair {
  SecurePair()
      : master(SecureConfig(SenderRole::kSlave, keys.key)), slave(SecureConfig(SenderRole::kMaster, keys.key)) {
    master.SetPeer("127.0.0.1", slave.local_port());
    slave.SetPeer("127.0.0.1", master.local_port());
  }
  KeyDir keys;
  UdpLink master;
  UdpLink slave;
};

TEST(SecureUdpLink, HandshakeThenSamplesBothWays) {
  SecurePair p;
  EXPECT_EQ(p.master.session_epoch(), 0u);
  EXPECT_FALSE(p.master.Send(MakeSample(SenderRole::kMaster, 0)));  // no session yet: nothing sent, no error
  EXPECT_EQ(p.master.counters().send_no_session, 1u);
  EXPECT_EQ(p.master.counters().send_errors, 0u);
  ASSERT_TRUE(Establish(p.master, p.slave));
  EXPECT_EQ(p.master.session_epoch(), 1u);
  EXPECT_EQ(p.slave.session_epoch(), 1u);

  std::uint32_t master_sequence = 1000;  // the frame sequence replaces it: the receiver sees 0, 1, 2, ...
  proto::SampleMessage got;
  ASSERT_TRUE(Deliver(p.master, p.slave, SenderRole::kMaster, master_sequence, got));
  EXPECT_EQ(got.sender, SenderRole::kMaster);
  EXPECT_EQ(got.dof, 3);
  std::uint32_t slave_sequence = 0;
  ASSERT_TRUE(Deliver(p.slave, p.master, SenderRole::kSlave, slave_sequence, got));
  EXPECT_EQ(got.sender, SenderRole::kSlave);
  EXPECT_EQ(p.master.counters().handshakes_started, 1u);
  EXPECT_EQ(p.master.counters().handshake_messages, 1u);  // the welcome
  EXPECT_GE(p.slave.counters().handshake_messages, 1u);   // the hello (and the confirm)
  EXPECT_EQ(p.slave.counters().rejected, 0u);
  test::ExpectCountersBalance(p.master.counters());
  test::ExpectCountersBalance(p.slave.counters());
  EXPECT_THAT(p.master.Describe(), ::testing::HasSubstr("authenticated: psk"));
}

TEST(SecureUdpLink, UnauthenticatedDatagramsFromThePeerAddressAreCountedNeverApplied) {
  SecurePair p;
  ASSERT_TRUE(Establish(p.master, p.slave));
  std::uint32_t sequence = 0;
  proto::SampleMessage got;
  ASSERT_TRUE(Deliver(p.master, p.slave, SenderRole::kMaster, sequence, got));
  // The attacker holds the peer's address: here, by making the slave's configured peer the attacker's socket
  // (what a raw socket with a spoofed source, or a process on a crashed master's port, achieves). The session
  // keeps running; only authenticated frames of it count.
  asio::io_context io;
  udp::socket spoof(io, udp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
  p.slave.SetPeer("127.0.0.1", spoof.local_endpoint().port());
  const udp::endpoint slave_end(asio::ip::make_address("127.0.0.1"), p.slave.local_port());
  // A version-1 sample with the shutdown flag, a valid CRC and a huge sequence: what took over a version-1 link.
  proto::SampleMessage forged = MakeSample(SenderRole::kMaster, 0x7FFFFFFF);
  forged.flags = proto::kFlagEnabled | proto::kFlagShutdown;
  forged.position_m[0] = -0.5;
  std::vector<std::uint8_t> v1(proto::MaxEncodedSampleSize());
  v1.resize(proto::EncodeSample(forged, v1));
  for (int i = 0; i < 10; ++i) spoof.send_to(asio::buffer(v1), slave_end);
  std::vector<std::uint8_t> junk(120, 0xAB);
  for (int i = 0; i < 5; ++i) spoof.send_to(asio::buffer(junk), slave_end);
  proto::SampleMessage polled = got;
  const LinkCounters& c = p.slave.counters();
  const std::uint64_t before = c.received;
  for (int i = 0; i < 200 && c.received < before + 15; ++i) {
    EXPECT_FALSE(p.slave.Poll(polled));
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  EXPECT_EQ(Secure(c, SecureReceiveStatus::kInsecure), 10u);
  EXPECT_EQ(Secure(c, SecureReceiveStatus::kMalformed), 5u);
  EXPECT_EQ(c.rejected, 15u);
  EXPECT_EQ(polled.position_m[0], got.position_m[0]);
  test::ExpectCountersBalance(c);
}

TEST(SecureUdpLink, AMasterRestartIsANewSessionAndTheOldOneIsDead) {
  KeyDir keys;
  UdpLink slave(SecureConfig(SenderRole::kMaster, keys.key));
  std::uint16_t master_port = 0;
  for (int run = 1; run <= 2; ++run) {
    UdpLinkConfig mc = SecureConfig(SenderRole::kSlave, keys.key);
    mc.bind_port = master_port;  // the restarted master binds the same port again
    UdpLink master(mc);
    master_port = master.local_port();
    master.SetPeer("127.0.0.1", slave.local_port());
    slave.SetPeer("127.0.0.1", master_port);
    ASSERT_TRUE(Establish(master, slave));
    std::uint32_t sequence = 0;
    proto::SampleMessage got;
    ASSERT_TRUE(Deliver(master, slave, SenderRole::kMaster, sequence, got));
    EXPECT_EQ(slave.session_epoch(), static_cast<std::uint64_t>(run));
    EXPECT_EQ(master.session_epoch(), 1u);  // a new process: its first session
    EXPECT_LT(got.sequence, 200u) << "the sequence starts again at 0 in a new session";
  }
  EXPECT_EQ(slave.counters().sessions, 2u);
  test::ExpectCountersBalance(slave.counters());
}

TEST(SecureUdpLink, TheMasterReHandshakesWhenTheSlaveRestarts) {
  KeyDir keys;
  UdpLink master(SecureConfig(SenderRole::kSlave, keys.key));
  std::uint16_t slave_port = 0;
  for (int run = 1; run <= 2; ++run) {
    UdpLinkConfig sc = SecureConfig(SenderRole::kMaster, keys.key);
    sc.bind_port = slave_port;
    UdpLink slave(sc);
    slave_port = slave.local_port();
    slave.SetPeer("127.0.0.1", master.local_port());
    master.SetPeer("127.0.0.1", slave_port);
    // The new slave has no session: the master's frames are no_session there until the master, finding the
    // slave silent for peer_silence_ms, sends a new hello.
    proto::SampleMessage got;
    bool both = false;
    std::uint32_t sequence = 0;
    for (int i = 0; i < 2000 && !both; ++i) {
      (void)master.Send(MakeSample(SenderRole::kMaster, sequence++));
      (void)slave.Send(MakeSample(SenderRole::kSlave, sequence));
      const bool a = master.Poll(got) && master.session_epoch() == static_cast<std::uint64_t>(run);
      const bool b = slave.Poll(got);
      both = a && b;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    ASSERT_TRUE(both) << "run " << run;
  }
  EXPECT_EQ(master.session_epoch(), 2u);
  EXPECT_GE(master.counters().handshakes_started, 2u);
}

TEST(SecureUdpLink, SteadyStateSendAndPollDoNotAllocate) {
  SecurePair p;
  ASSERT_TRUE(Establish(p.master, p.slave));
  std::uint32_t sequence = 0;
  proto::SampleMessage got;
  ASSERT_TRUE(Deliver(p.master, p.slave, SenderRole::kMaster, sequence, got));
  ASSERT_TRUE(Deliver(p.slave, p.master, SenderRole::kSlave, sequence, got));
  std::uint64_t allocations = 0;
  int received = 0;
  {
    teleop::test::AllocationCounter counter;
    for (int i = 0; i < 200; ++i) {
      if (!p.master.Send(MakeSample(SenderRole::kMaster, sequence++))) break;
      (void)p.slave.Send(MakeSample(SenderRole::kSlave, sequence));
      if (p.slave.Poll(got)) ++received;
      (void)p.master.Poll(got);
    }
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_GT(received, 150);
}

TEST(SecureUdpLink, KeyFileProblemsAreSetUpErrorsWithTheFix) {
  KeyDir keys;
  ASSERT_EQ(chmod(keys.key.c_str(), 0644), 0);
  try {
    UdpLink link(SecureConfig(SenderRole::kSlave, keys.key));
    FAIL() << "a group/other-readable key was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("chmod 600 " + keys.key));
  }
  try {
    UdpLink link(SecureConfig(SenderRole::kSlave, keys.dir.File("missing.key")));
    FAIL() << "a missing key was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("teleop-keygen"));
  }
}

TEST(SecureUdpLink, MakeLinkRefusesPskOnCan) {
  KeyDir keys;
  LinkConfig config;
  config.transport = "emulated-can";
  config.security.mode = LinkSecurityMode::kPsk;
  config.security.key_file = keys.key;
  try {
    (void)MakeLink(config, SenderRole::kMaster);
    FAIL() << "psk on CAN was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("link.security.mode: insecure"));
  }
}

}  // namespace
}  // namespace teleop::transport
