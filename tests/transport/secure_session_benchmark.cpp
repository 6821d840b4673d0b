// Cost per datagram of the authenticated session (docs/security.md, "Cost"): seal, open, both, by DOF; the
// rejection paths a flood exercises; and one handshake.
#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>
#include <cstdio>

#include "teleop/proto/can/bus_load.hpp"
#include "teleop/proto/can/can_frame.hpp"
#include "teleop/proto/can/frame_layout.hpp"
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

// The caller's cost of answering a fresh, authentic hello (the slave's cycle, docs/security.md "X25519 and the
// cycle"): inline (Arg 0), the two X25519 operations and the key derivation; offloaded (Arg 1, what UdpLink runs),
// the MAC check and the hand-over to the helper thread only (the helper's work and the next cycle's Pump(), which
// copies the result, are outside the timing).
void BM_AnswerHello(benchmark::State& state) {
  const bool offload = state.range(0) != 0;
  SecureSessionConfig sc = Config(SenderRole::kSlave, 1);
  sc.max_handshakes_per_s = 1e12;
  sc.handshake_burst = 1e12;
  sc.offload_key_exchange = offload;
  SecureSession slave(sc, Key());
  SecureSession master(Config(SenderRole::kMaster, 1), Key());
  std::array<std::uint8_t, teleop::proto::kMaxSecureMessageSize> hello{};
  std::array<std::uint8_t, teleop::proto::kMaxSecureMessageSize> reply{};
  teleop::proto::SampleMessage out{};
  std::uint64_t now = 1;
  std::uint64_t welcomes = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const std::size_t n = master.BeginHandshake(hello, ++now);
    state.ResumeTiming();
    const auto r = slave.Receive(std::span(hello).first(n), now, reply, out);
    welcomes += r.reply_size > 0 ? 1 : 0;
    if (offload) {
      state.PauseTiming();  // the helper's work and the Pump() that installs it
      while (slave.Pump(reply) == 0) {
      }
      ++welcomes;
      state.ResumeTiming();
    }
  }
  state.counters["welcomes"] = static_cast<double>(welcomes);
}
BENCHMARK(BM_AnswerHello)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// A replayed hello: a copy of the last one answered (the cached welcome) or an older one (refused by its
// timestamp after the MAC). Neither does an X25519.
void BM_ReplayedHello(benchmark::State& state) {
  const bool older = state.range(0) != 0;
  SecureSession slave(Config(SenderRole::kSlave, 1), Key());
  SecureSession master(Config(SenderRole::kMaster, 1), Key());
  std::array<std::uint8_t, teleop::proto::kMaxSecureMessageSize> old_hello{};
  std::array<std::uint8_t, teleop::proto::kMaxSecureMessageSize> hello{};
  std::array<std::uint8_t, teleop::proto::kMaxSecureMessageSize> reply{};
  teleop::proto::SampleMessage out{};
  const std::size_t n_old = master.BeginHandshake(old_hello, 100);
  const std::size_t n = master.BeginHandshake(hello, 200);
  static_cast<void>(slave.Receive(std::span(hello).first(n), 1, reply, out));
  const auto replay = older ? std::span(old_hello).first(n_old) : std::span(hello).first(n);
  std::uint64_t now = 1;
  for (auto _ : state) benchmark::DoNotOptimize(slave.Receive(replay, ++now, reply, out));
}
BENCHMARK(BM_ReplayedHello)->Arg(0)->Arg(1);

// What authentication would cost on CAN (docs/security.md, "CAN"): the bus load of the plain layout (docs/can.md)
// and of the two options that fit the frame budget: classic CAN adds one 8-byte frame per cycle (2 bytes of
// sequence extension + a 48-bit truncated MAC); CAN FD adds 12 bytes to its one frame (4 bytes of sequence + a
// 64-bit truncated MAC), rounded up to an FD length. Both directions, worst-case stuffing, at `rate_hz`.
void PrintCanBudget() {
  namespace can = teleop::proto::can;
  const can::CanBitrates rates{};
  std::printf("CAN bus load, both directions, worst-case stuffing (limit 70 %%)\n");
  std::printf("%-22s %4s %8s %10s %14s %10s\n", "bus", "DOF", "rate", "plain", "authenticated", "auth bytes");
  for (const bool fd : {false, true}) {
    for (const int dof : {1, 2, 3, 6}) {
      for (const double rate_hz : {500.0, 1000.0}) {
        can::CanWireFormat format{};
        format.dof = dof;
        format.fd = fd;
        const can::BusLoad plain = can::ComputeBusLoad(format, rates, rate_hz);
        double auth_time_s = plain.wire_time_per_cycle_s;
        int auth_bytes = 0;
        if (fd) {
          const std::size_t bytes = can::RoundUpToFdLength(static_cast<std::size_t>(can::FdDataBytes(dof)) + 12);
          auth_time_s = can::FrameTime_s(true, true, false, bytes, rates);
          auth_bytes = static_cast<int>(bytes) - plain.data_bytes_per_cycle;
        } else {
          auth_time_s += can::FrameTime_s(false, false, false, 8, rates);
          auth_bytes = 8;
        }
        std::printf("%-22s %4d %6.0f Hz %8.1f %% %12.1f %% %10d\n", fd ? "FD 1/5 Mbit/s" : "classic 1 Mbit/s", dof,
                    rate_hz, 100.0 * plain.load, 100.0 * 2.0 * auth_time_s * rate_hz, auth_bytes);
      }
    }
  }
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  PrintCanBudget();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
