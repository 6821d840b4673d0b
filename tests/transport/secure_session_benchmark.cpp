// Cost per datagram of the authenticated session (docs/security.md, "Cost"): seal, open, both, by DOF; the
// rejection paths a flood exercises; and one handshake.
#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>

#include "teleop/transport/secure_session.hpp"

namespace {

using teleop::proto::SenderRole;
using teleop::transport::PreSharedKey;
using teleop::transport::SecureSession;
using teleop::transport::SecureSessionConfig;

PreSharedKey Key() {
  std::array<std::uint8_t, teleop::transport::kPreSharedKeyBytes> bytes{};
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(3 * i + 1);
  return PreSharedKey(bytes);
}

SecureSessionConfig Config(SenderRole role, int dof) {
  SecureSessionConfig c;
  c.role = role;
  c.dof = dof;
  c.max_datagrams_per_s = 1e12;  // measure the crypto, not the limiter
  c.datagram_burst = 1e12;
  return c;
}

struct Pair {
  explicit Pair(int dof)
      : master(Config(SenderRole::kMaster, dof), Key()), slave(Config(SenderRole::kSlave, dof), Key()) {
    std::array<std::uint8_t, teleop::proto::kMaxSecureMessageSize> a{};
    std::array<std::uint8_t, teleop::proto::kMaxSecureMessageSize> b{};
    teleop::proto::SampleMessage unused{};
    const std::size_t hello = master.BeginHandshake(a);
    const auto welcome = slave.Receive(std::span(a).first(hello), 1, b, unused);
    const auto confirm = master.Receive(std::span(b).first(welcome.reply_size), 1, a, unused);
    static_cast<void>(slave.Receive(std::span(a).first(confirm.reply_size), 1, b, unused));
    sample.sender = SenderRole::kMaster;
    sample.dof = static_cast<std::uint8_t>(dof);
    for (int i = 0; i < dof; ++i) {
      sample.position_m[i] = 0.01 * i;
      sample.velocity_m_per_s[i] = 0.1;
      sample.force_N[i] = 1.0;
    }
  }
  SecureSession master;
  SecureSession slave;
  teleop::proto::SampleMessage sample{};
  std::array<std::uint8_t, teleop::proto::kMaxSecureFrameSize> frame{};
  std::array<std::uint8_t, teleop::proto::kMaxSecureMessageSize> reply{};
  teleop::proto::SampleMessage out{};
};

void BM_Seal(benchmark::State& state) {
  Pair p(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(p.master.Seal(p.sample, p.frame));
}
BENCHMARK(BM_Seal)->Arg(1)->Arg(3)->Arg(6);

void BM_SealAndOpen(benchmark::State& state) {
  Pair p(static_cast<int>(state.range(0)));
  std::uint64_t now = 1;
  std::uint64_t accepted = 0;
  for (auto _ : state) {
    p.sample.sender_time_ns = now * 1000;
    const std::size_t n = p.master.Seal(p.sample, p.frame);
    const auto r = p.slave.Receive(std::span(p.frame).first(n), ++now, p.reply, p.out);
    accepted += r.status == teleop::transport::SecureReceiveStatus::kSample ? 1 : 0;
  }
  state.counters["accepted"] = static_cast<double>(accepted);
  state.counters["bytes"] = static_cast<double>(p.master.Seal(p.sample, p.frame));
}
BENCHMARK(BM_SealAndOpen)->Arg(1)->Arg(3)->Arg(6);

// A forged frame: full AEAD verification, then rejection (the cost of a flood that passes the rate limiter).
void BM_RejectForged(benchmark::State& state) {
  Pair p(static_cast<int>(state.range(0)));
  const std::size_t n = p.master.Seal(p.sample, p.frame);
  p.frame[40] ^= 1;
  std::uint64_t now = 1;
  for (auto _ : state) benchmark::DoNotOptimize(p.slave.Receive(std::span(p.frame).first(n), ++now, p.reply, p.out));
}
BENCHMARK(BM_RejectForged)->Arg(6);

// A replayed frame: rejected by the window before the AEAD.
void BM_RejectReplay(benchmark::State& state) {
  Pair p(6);
  const std::size_t n = p.master.Seal(p.sample, p.frame);
  std::uint64_t now = 1;
  static_cast<void>(p.slave.Receive(std::span(p.frame).first(n), ++now, p.reply, p.out));
  for (auto _ : state) benchmark::DoNotOptimize(p.slave.Receive(std::span(p.frame).first(n), ++now, p.reply, p.out));
}
BENCHMARK(BM_RejectReplay);

void BM_Handshake(benchmark::State& state) {
  for (auto _ : state) {
    Pair p(1);
    benchmark::DoNotOptimize(p.slave.session_id());
  }
}
BENCHMARK(BM_Handshake)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
