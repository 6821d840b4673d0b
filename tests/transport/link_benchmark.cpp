// Cost of one cycle's link work: Send + Poll on UDP loopback (plain and authenticated) and on the emulated link,
// and SequenceTracker.
// Prints ns per iteration; not a test.
#include <benchmark/benchmark.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include "teleop/transport/emulated_link.hpp"
#include "teleop/transport/impaired_link.hpp"
#include "teleop/transport/secure_key_file.hpp"
#include "teleop/transport/udp_link.hpp"
#include "test_utilities/temp_dir.hpp"

namespace {

using teleop::proto::SampleMessage;
using teleop::proto::SenderRole;

SampleMessage Sample(SenderRole sender, int dof) {
  SampleMessage m;
  m.sender = sender;
  m.dof = static_cast<std::uint8_t>(dof);
  return m;
}

// One loopback datagram per iteration: master Send, slave Poll (drain, decode, classify).
void BM_UdpSendPoll(benchmark::State& state) {
  teleop::transport::UdpLinkConfig master_config;
  master_config.expected_peer = SenderRole::kSlave;
  teleop::transport::UdpLinkConfig slave_config;
  slave_config.expected_peer = SenderRole::kMaster;
  teleop::transport::UdpLink master(master_config);
  teleop::transport::UdpLink slave(slave_config);
  master.SetPeer("127.0.0.1", slave.local_port());
  slave.SetPeer("127.0.0.1", master.local_port());
  SampleMessage m = Sample(SenderRole::kMaster, static_cast<int>(state.range(0)));
  SampleMessage got;
  std::int64_t fresh = 0;
  for (auto _ : state) {
    ++m.sequence;
    benchmark::DoNotOptimize(master.Send(m));
    fresh += slave.Poll(got) ? 1 : 0;
  }
  state.counters["fresh_per_poll"] = static_cast<double>(fresh) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_UdpSendPoll)->Arg(1)->Arg(6);

// The same with link.security.mode psk: master Seal + send, slave drain + Receive (window, AEAD open, decode,
// plausibility) + classify. The difference to BM_UdpSendPoll is what authentication adds per datagram at the link.
void BM_SecureUdpSendPoll(benchmark::State& state) {
  const int dof = static_cast<int>(state.range(0));
  const teleop::test::ScopedTempDir dir("link-benchmark");
  const std::string key = dir.File("teleop.key");
  teleop::transport::WriteNewKeyFile(key);
  auto config = [&](SenderRole expected_peer) {
    teleop::transport::UdpLinkConfig c;
    c.expected_peer = expected_peer;
    c.security.mode = teleop::transport::LinkSecurityMode::kPsk;
    c.security.key_file = key;
    c.security.session.dof = dof;
    c.security.session.max_datagrams_per_s = 1e7;  // the loop below is faster than any real link: measure, not drop
    c.security.session.datagram_burst = 1e6;
    c.peer_silence_ms = 1e9;  // no re-handshake inside the measurement
    return c;
  };
  teleop::transport::UdpLink master(config(SenderRole::kSlave));
  teleop::transport::UdpLink slave(config(SenderRole::kMaster));
  master.SetPeer("127.0.0.1", slave.local_port());
  slave.SetPeer("127.0.0.1", master.local_port());
  SampleMessage m = Sample(SenderRole::kMaster, dof);
  SampleMessage got;
  for (int i = 0; i < 1000 && (master.session_epoch() == 0 || slave.session_epoch() == 0); ++i) {
    (void)master.Poll(got);  // hello out, welcome in, confirm out
    (void)slave.Poll(got);
    (void)master.Send(m);  // the first frame also completes the slave's side
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  if (master.session_epoch() == 0 || slave.session_epoch() == 0) {
    state.SkipWithError("no session established");
    return;
  }
  std::int64_t fresh = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(master.Send(m));
    fresh += slave.Poll(got) ? 1 : 0;
  }
  state.counters["fresh_per_poll"] = static_cast<double>(fresh) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_SecureUdpSendPoll)->Arg(1)->Arg(6);

// An empty Poll: the cost of finding the socket empty (one recvfrom returning EAGAIN).
void BM_UdpEmptyPoll(benchmark::State& state) {
  teleop::transport::UdpLink link(teleop::transport::UdpLinkConfig{});
  SampleMessage got;
  for (auto _ : state) benchmark::DoNotOptimize(link.Poll(got));
}
BENCHMARK(BM_UdpEmptyPoll);

void BM_EmulatedSendAdvancePoll(benchmark::State& state) {
  teleop::transport::EmulatedLinkConfig config;
  config.delay_s = 0.002;
  auto pair = teleop::transport::MakeEmulatedLinkPair(config);
  SampleMessage m = Sample(SenderRole::kMaster, 6);
  SampleMessage got;
  for (auto _ : state) {
    ++m.sequence;
    benchmark::DoNotOptimize(pair.master->Send(m));
    pair.medium->Advance(0.001);
    benchmark::DoNotOptimize(pair.slave->Poll(got));
  }
}
BENCHMARK(BM_EmulatedSendAdvancePoll);

// link.emulate in a process: UDP loopback Send + Poll through ImpairedLink (20 ms delay, 5 ms jitter, 5 % loss,
// 1 % duplication and corruption) on the monotonic clock. The iterations come far faster than the 20 ms drain, so
// the 256-slot delay line is full: the worst case of its slot scans (at 1 kHz it holds about 25).
void BM_ImpairedUdpSendPoll(benchmark::State& state) {
  teleop::transport::UdpLinkConfig master_config;
  master_config.expected_peer = SenderRole::kSlave;
  teleop::transport::UdpLinkConfig slave_config;
  slave_config.expected_peer = SenderRole::kMaster;
  auto master = std::make_unique<teleop::transport::UdpLink>(master_config);
  auto slave = std::make_unique<teleop::transport::UdpLink>(slave_config);
  master->SetPeer("127.0.0.1", slave->local_port());
  slave->SetPeer("127.0.0.1", master->local_port());
  teleop::transport::ImpairmentConfig impairments;
  impairments.capacity = 256;
  impairments.delay_s = 0.020;
  impairments.jitter_s = 0.005;
  impairments.loss_probability = 0.05;
  impairments.duplicate_probability = 0.01;
  impairments.corrupt_probability = 0.01;
  teleop::transport::ImpairedLink impaired(std::move(slave), impairments, 1, SenderRole::kMaster);
  SampleMessage m = Sample(SenderRole::kMaster, 1);
  SampleMessage got;
  for (auto _ : state) {
    ++m.sequence;
    benchmark::DoNotOptimize(master->Send(m));
    benchmark::DoNotOptimize(impaired.Poll(got));
  }
}
BENCHMARK(BM_ImpairedUdpSendPoll);

void BM_SequenceTracker(benchmark::State& state) {
  teleop::transport::SequenceTracker tracker;
  teleop::transport::LinkCounters counters;
  std::uint32_t s = 0;
  for (auto _ : state) {
    s += (s % 17 == 0) ? 2 : 1;
    benchmark::DoNotOptimize(tracker.Observe(s, counters));
  }
}
BENCHMARK(BM_SequenceTracker);

}  // namespace

BENCHMARK_MAIN();
