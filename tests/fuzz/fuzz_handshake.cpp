// libFuzzer harness: the handshake of the authenticated session (common/src/transport/secure_session.cpp) over a
// network the input controls. Every message either end sends (hello, welcome, confirm, frames) is captured; the
// input is a script of up to 64 two-byte operations:
//   0 x: the master begins a handshake at its clock moved by x (bit 7 set: backwards; hellos must still grow)
//   1 i: deliver captured message i to its receiver (a duplicate or replay when it was delivered before)
//   2 i: deliver a copy of message i with one byte XORed (position and mask from the next two input bytes)
//   3 x: the master seals a frame;  4 x: the slave seals a frame
//   5 x: both clocks advance by x ms (the handshake bucket refills)
//   6 x: deliver the newest captured message again
// Properties: no crash or UB; counters balance at both ends; a mutated message is never accepted (neither a sample
// nor a handshake message); the slave's session is always one the master established; and availability: after any
// script, one clean exchange (a fresh hello, its welcome, its confirm) establishes the same session at both ends and
// carries a frame each way, so no sequence of duplicates, replays, forgeries or clock steps wedges the handshake.
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <span>
#include <vector>

#include "fuzz_check.hpp"
#include "teleop/transport/secure_session.hpp"

namespace {

using namespace teleop;
using proto::SenderRole;
using transport::SecureReceiveStatus;
using transport::SecureSession;
using Bytes = std::vector<std::uint8_t>;

transport::PreSharedKey Key() {
  std::array<std::uint8_t, transport::kPreSharedKeyBytes> bytes{};
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(11 * i + 7);
  return transport::PreSharedKey(bytes);
}

transport::SecureSessionConfig Config(SenderRole role) {
  transport::SecureSessionConfig c;
  c.role = role;
  c.dof = 1;
  c.max_speed_m_per_s = 1e6;  // plausibility is not what this harness is about
  c.max_force_N = 1e6;
  c.position_slack_m = 1e6;
  c.max_handshakes_per_s = 1.0;  // tight, so the bucket is exercised; op 5 refills it
  c.handshake_burst = 2.0;
  return c;
}

void CheckBalanced(const transport::SecureCounters& c) {
  TELEOP_FUZZ_CHECK(std::accumulate(c.by_status.begin(), c.by_status.end(), std::uint64_t{0}) == c.received);
}

struct Captured {
  Bytes bytes;
  bool to_slave = true;
};

struct Net {
  SecureSession master{Config(SenderRole::kMaster), Key()};
  SecureSession slave{Config(SenderRole::kSlave), Key()};
  std::vector<Captured> captured;
  std::vector<std::uint64_t> master_ids;
  std::uint64_t now_ns = 1'000'000'000;
  std::uint64_t clock_ns = 1'000'000'000'000;
  std::uint64_t tx_count = 0;
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> reply{};
  proto::SampleMessage out{};

  void Capture(std::span<const std::uint8_t> bytes, bool to_slave) {
    if (captured.size() < 256) captured.push_back({Bytes(bytes.begin(), bytes.end()), to_slave});
  }
  void NoteMasterId() {
    const std::uint64_t id = master.session_id();
    if (id != 0 && std::find(master_ids.begin(), master_ids.end(), id) == master_ids.end()) master_ids.push_back(id);
  }
  transport::SecureReceiveResult Deliver(const Bytes& bytes, bool to_slave) {
    SecureSession& to = to_slave ? slave : master;
    const auto r = to.Receive(bytes, now_ns, reply, out);
    if (r.reply_size > 0) Capture(std::span(reply).first(r.reply_size), !to_slave);
    NoteMasterId();
    return r;
  }
  Bytes Seal(SecureSession& from, SenderRole role) {
    proto::SampleMessage m{};
    m.sender = role;
    m.dof = 1;
    m.sender_time_ns = ++tx_count * 1'000'000;
    m.position_m[0] = 0.001;
    std::array<std::uint8_t, proto::kMaxSecureFrameSize> frame{};
    const std::size_t n = from.Seal(m, frame);
    return Bytes(frame.begin(), frame.begin() + n);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Net net;
  std::size_t at = 0;
  const auto next = [&]() -> std::uint8_t { return at < size ? data[at++] : 0; };
  for (int step = 0; step < 64 && at < size; ++step) {
    const std::uint8_t op = next() % 7;
    const std::uint8_t x = next();
    switch (op) {
      case 0: {
        const std::uint64_t delta = static_cast<std::uint64_t>(x & 0x7F) * 1'000'000;
        net.clock_ns = (x & 0x80) != 0 ? net.clock_ns - std::min(delta, net.clock_ns) : net.clock_ns + delta;
        const std::size_t n = net.master.BeginHandshake(net.reply, net.clock_ns);
        TELEOP_FUZZ_CHECK(n == proto::secure_wire::kHelloSize);
        net.Capture(std::span(net.reply).first(n), true);
        break;
      }
      case 1:
      case 6: {
        if (net.captured.empty()) break;
        const Captured c = op == 1 ? net.captured[x % net.captured.size()] : net.captured.back();
        static_cast<void>(net.Deliver(c.bytes, c.to_slave));
        break;
      }
      case 2: {
        if (net.captured.empty()) break;
        Captured c = net.captured[x % net.captured.size()];
        const std::size_t position = next() % c.bytes.size();
        c.bytes[position] ^= static_cast<std::uint8_t>(next() | 1);
        const auto r = net.Deliver(c.bytes, c.to_slave);
        TELEOP_FUZZ_CHECK(r.status != SecureReceiveStatus::kSample && r.status != SecureReceiveStatus::kHandshake);
        break;
      }
      case 3:
      case 4: {
        const bool from_master = op == 3;
        const Bytes frame =
            net.Seal(from_master ? net.master : net.slave, from_master ? SenderRole::kMaster : SenderRole::kSlave);
        if (!frame.empty()) net.Capture(frame, from_master);
        break;
      }
      default:
        net.now_ns += static_cast<std::uint64_t>(x) * 1'000'000;
        break;
    }
    const std::uint64_t slave_id = net.slave.session_id();
    TELEOP_FUZZ_CHECK(slave_id == 0 ||
                      std::find(net.master_ids.begin(), net.master_ids.end(), slave_id) != net.master_ids.end());
  }
  CheckBalanced(net.master.counters());
  CheckBalanced(net.slave.counters());

  // Availability: a clean exchange after a pause long enough to refill the handshake bucket.
  net.now_ns += 10'000'000'000;
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> hello{};
  const std::size_t n = net.master.BeginHandshake(hello, net.clock_ns);
  const auto w = net.slave.Receive(std::span(hello).first(n), net.now_ns, net.reply, net.out);
  TELEOP_FUZZ_CHECK(w.status == SecureReceiveStatus::kHandshake && w.reply_size == proto::secure_wire::kWelcomeSize);
  const Bytes welcome(net.reply.begin(), net.reply.begin() + w.reply_size);
  const auto c = net.master.Receive(welcome, net.now_ns, net.reply, net.out);
  TELEOP_FUZZ_CHECK(c.status == SecureReceiveStatus::kHandshake && c.reply_size == proto::secure_wire::kConfirmSize);
  const Bytes confirm(net.reply.begin(), net.reply.begin() + c.reply_size);
  TELEOP_FUZZ_CHECK(net.slave.Receive(confirm, net.now_ns, net.reply, net.out).status ==
                    SecureReceiveStatus::kHandshake);
  TELEOP_FUZZ_CHECK(net.master.session_id() != 0 && net.master.session_id() == net.slave.session_id());
  TELEOP_FUZZ_CHECK(
      net.slave.Receive(net.Seal(net.master, SenderRole::kMaster), net.now_ns, net.reply, net.out).status ==
      SecureReceiveStatus::kSample);
  TELEOP_FUZZ_CHECK(
      net.master.Receive(net.Seal(net.slave, SenderRole::kSlave), net.now_ns, net.reply, net.out).status ==
      SecureReceiveStatus::kSample);
  return 0;
}
