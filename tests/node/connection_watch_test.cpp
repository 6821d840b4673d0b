// The connection watch (teleop/node/connection_watch.hpp): the status line for each way a pair fails to connect, the
// counters it reads from the link, and the give-up after --connect-timeout with what it writes into the summary.
#include "teleop/node/connection_watch.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>

#include "teleop/node/exit_codes.hpp"
#include "teleop/version.hpp"

namespace teleop::node {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using transport::SecureReceiveStatus;

ConnectionFacts Waiting(Role role, bool authenticated) {
  ConnectionFacts f;
  f.role = role;
  f.peer_address = "10.77.0.2:47002";
  f.authenticated = authenticated;
  f.waited_s = 4.0;
  return f;
}

std::uint64_t& Secure(transport::LinkCounters& c, SecureReceiveStatus s) {
  return c.secure_rejected_by_reason[static_cast<std::size_t>(s)];
}

TEST(ConnectionWatch, NoAnswerNamesThePeerAndWhatWasSent) {
  ConnectionFacts f = Waiting(Role::kMaster, true);
  f.handshakes_started = 40;
  EXPECT_EQ(
      DescribeConnection(f),
      "waiting for the slave at 10.77.0.2:47002 (4.0 s): 40 hellos sent, no answer (is it running? is the address "
      "right? a firewall? the same key?)");
  f = Waiting(Role::kMaster, false);
  f.sent = 4000;
  EXPECT_THAT(DescribeConnection(f), HasSubstr(": 4000 samples sent, no answer (is it running?"));
  f = Waiting(Role::kSlave, true);
  EXPECT_THAT(DescribeConnection(f), HasSubstr("waiting for the master at 10.77.0.2:47002 (4.0 s): no hello received"));
}

TEST(ConnectionWatch, PortUnreachableSaysNothingListens) {
  ConnectionFacts f = Waiting(Role::kMaster, true);
  f.handshakes_started = 10;
  f.unreachable = 9;
  EXPECT_THAT(
      DescribeConnection(f),
      HasSubstr("10 hellos sent, no answer; 9 answered 'port unreachable': nothing listens at 10.77.0.2:47002"));
}

TEST(ConnectionWatch, AnotherKeyIsNamed) {
  transport::LinkCounters c;
  c.received = 12;
  c.rejected = 12;
  Secure(c, SecureReceiveStatus::kBadHandshakeTag) = 12;
  ConnectionFacts f = Waiting(Role::kSlave, true);
  FillFromCounters(c, f);
  EXPECT_THAT(DescribeConnection(f),
              HasSubstr(": the peer answers but its key differs (12 handshakes refused: bad tag)"));
}

TEST(ConnectionWatch, AnotherProtocolVersionNamesBoth) {
  transport::LinkCounters c;
  c.received = c.rejected = 3;
  c.rejected_by_reason[static_cast<std::size_t>(proto::DecodeStatus::kBadVersion)] = 3;
  c.peer_protocol_version = 9;
  ConnectionFacts f = Waiting(Role::kMaster, false);
  FillFromCounters(c, f);
  EXPECT_THAT(DescribeConnection(f),
              HasSubstr(std::string("the peer runs wire protocol version 9 and this process runs ") +
                        SoftwareVersion() + " (wire protocol 1, authenticated 2)"));
  // The other security mode is its own message, on either side.
  c.peer_protocol_version = proto::kSecureProtocolVersion;
  FillFromCounters(c, f);
  EXPECT_THAT(DescribeConnection(f), HasSubstr("the peer uses an authenticated link"));
  transport::LinkCounters v1;
  Secure(v1, SecureReceiveStatus::kInsecure) = 5;
  v1.peer_protocol_version = proto::kProtocolVersion;
  f = Waiting(Role::kSlave, true);
  FillFromCounters(v1, f);
  EXPECT_THAT(DescribeConnection(f), HasSubstr("the peer sends unauthenticated samples"));
}

TEST(ConnectionWatch, ConnectedSaysSo) {
  ConnectionFacts f = Waiting(Role::kMaster, true);
  f.connected = true;
  EXPECT_EQ(DescribeConnection(f), "connected");
}

// A run whose peer never became usable: after connect_timeout_s of the run's own clock the watch gives up (once),
// and Finish writes the diagnosis, connected = false and the stop reason; the exit status is kExitNeverConnected.
TEST(ConnectionWatch, GivesUpAfterTheTimeoutAndWritesTheSummary) {
  ConnectionWatch::Config config;
  config.base = Waiting(Role::kMaster, true);
  config.rate_hz = 1000.0;
  config.status_interval_s = 0.0;
  config.connect_timeout_s = 1.0;
  std::mutex mutex;
  std::condition_variable cv;
  int give_ups = 0;
  ConnectionWatch watch(config, [&] {
    const std::lock_guard<std::mutex> lock(mutex);
    ++give_ups;
    cv.notify_all();
  });
  transport::LinkCounters link;
  link.handshakes_started = 7;
  runtime::TelemetryRecord row;
  CycleRecord record;
  record.telemetry = &row;
  record.link = &link;
  row.cycle = 0;
  row.time_s = 0.5;  // before the timeout: no give-up
  watch.OnCycle(record);
  EXPECT_EQ(watch.Snapshot().handshakes_started, 7u);
  EXPECT_FALSE(watch.gave_up());
  row.cycle = 100;
  row.time_s = 1.5;
  watch.OnCycle(record);
  {
    std::unique_lock<std::mutex> lock(mutex);
    ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(10), [&] { return give_ups > 0; }));
  }
  EXPECT_TRUE(watch.gave_up());
  RunSummary summary;
  summary.link = link;
  watch.Finish(summary);
  EXPECT_EQ(give_ups, 1);
  EXPECT_FALSE(summary.connected);
  EXPECT_EQ(summary.stop_reason, "connect timeout");
  EXPECT_THAT(summary.connection, HasSubstr("NEVER CONNECTED: waiting for the slave at 10.77.0.2:47002"));
  EXPECT_THAT(summary.connection, HasSubstr("7 hellos sent"));
  EXPECT_EQ(ExitCodeFor(summary), kExitNeverConnected);
}

TEST(ConnectionWatch, AUsableCycleMeansConnected) {
  ConnectionWatch::Config config;
  config.connect_timeout_s = 0.0;
  ConnectionWatch watch(config, nullptr);
  transport::LinkCounters link;
  runtime::TelemetryRecord row;
  CycleRecord record;
  record.telemetry = &row;
  record.link = &link;
  record.peer_fresh = true;
  row.cycle = 3;  // not a decimated cycle: connected is noted on every cycle
  watch.OnCycle(record);
  RunSummary summary;
  watch.Finish(summary);
  EXPECT_TRUE(summary.connected);
  EXPECT_EQ(summary.connection, "connected");
  EXPECT_THAT(summary.stop_reason, Not(HasSubstr("connect")));
  EXPECT_EQ(ExitCodeFor(summary), kExitOk);
}

}  // namespace
}  // namespace teleop::node
