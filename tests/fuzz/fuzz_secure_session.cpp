// libFuzzer harness: the authenticated session's receive path (common/src/transport/secure_session.cpp) on both
// ends of an established session. The first input byte picks the mode:
//   0: the rest is one datagram, fed to the slave and to the master;
//   1: the rest is XORed onto a genuine sealed frame (near-valid frames, the forger's best guess), fed to the slave;
//   2: the rest is XORed onto a genuine hello, fed to a fresh slave.
// Properties: no crash or UB; nothing but an untouched genuine frame is accepted; counters balance; the genuine
// frame is still accepted afterwards (no input moved the replay window).
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <span>

#include "fuzz_check.hpp"
#include "teleop/transport/secure_session.hpp"

namespace {

using namespace teleop;
using proto::SenderRole;
using transport::SecureReceiveStatus;
using transport::SecureSession;

transport::PreSharedKey Key() {
  std::array<std::uint8_t, transport::kPreSharedKeyBytes> bytes{};
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(5 * i + 3);
  return transport::PreSharedKey(bytes);
}

transport::SecureSessionConfig Config(SenderRole role) {
  transport::SecureSessionConfig c;
  c.role = role;
  c.dof = 2;
  c.max_datagrams_per_s = 1e12;
  c.datagram_burst = 1e12;
  c.max_handshakes_per_s = 1e12;
  c.handshake_burst = 1e12;
  return c;
}

void CheckBalanced(const transport::SecureCounters& c) {
  const std::uint64_t sum = std::accumulate(c.by_status.begin(), c.by_status.end(), std::uint64_t{0});
  TELEOP_FUZZ_CHECK(sum == c.received);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  SecureSession master(Config(SenderRole::kMaster), Key());
  SecureSession slave(Config(SenderRole::kSlave), Key());
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> a{};
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> b{};
  proto::SampleMessage out{};
  std::uint64_t now = 1;
  const std::size_t hello_size = master.BeginHandshake(a);
  std::array<std::uint8_t, proto::kMaxSecureMessageSize> hello{};
  std::copy(a.begin(), a.end(), hello.begin());
  const auto welcome = slave.Receive(std::span(a).first(hello_size), ++now, b, out);
  const auto confirm = master.Receive(std::span(b).first(welcome.reply_size), ++now, a, out);
  TELEOP_FUZZ_CHECK(slave.Receive(std::span(a).first(confirm.reply_size), ++now, b, out).status ==
                    SecureReceiveStatus::kHandshake);

  proto::SampleMessage sample{};
  sample.sender = SenderRole::kMaster;
  sample.dof = 2;
  sample.position_m = {0.01, 0.02};
  std::array<std::uint8_t, proto::kMaxSecureFrameSize> frame{};
  const std::size_t frame_size = master.Seal(sample, frame);
  TELEOP_FUZZ_CHECK(frame_size > 0);

  const std::span<const std::uint8_t> rest(data + 1, size - 1);
  std::array<std::uint8_t, 1024> buffer{};
  switch (data[0] % 3) {
    case 0: {
      static_cast<void>(slave.Receive(rest, ++now, b, out));
      static_cast<void>(master.Receive(rest, ++now, b, out));
      const bool is_genuine = rest.size() == frame_size && std::equal(rest.begin(), rest.end(), frame.begin());
      TELEOP_FUZZ_CHECK(is_genuine || slave.counters().count(SecureReceiveStatus::kSample) == 0);
      TELEOP_FUZZ_CHECK(master.counters().count(SecureReceiveStatus::kSample) == 0);
      break;
    }
    case 1: {
      const std::size_t n = std::min(buffer.size(), std::max(frame_size, rest.size()));
      std::copy_n(frame.begin(), frame_size, buffer.begin());
      bool changed = n != frame_size;  // the bytes fed differ from the genuine frame
      for (std::size_t i = 0; i < rest.size() && i < n; ++i) {
        buffer[i] ^= rest[i];
        changed |= rest[i] != 0;
      }
      const auto r = slave.Receive(std::span(buffer).first(n), ++now, b, out);
      TELEOP_FUZZ_CHECK(!changed || r.status != SecureReceiveStatus::kSample);
      break;
    }
    default: {
      SecureSession fresh(Config(SenderRole::kSlave), Key());
      const std::size_t n = std::min(buffer.size(), std::max(hello_size, rest.size()));
      std::copy_n(hello.begin(), hello_size, buffer.begin());
      for (std::size_t i = 0; i < rest.size() && i < n; ++i) buffer[i] ^= rest[i];
      static_cast<void>(fresh.Receive(std::span(buffer).first(n), ++now, b, out));
      CheckBalanced(fresh.counters());
      TELEOP_FUZZ_CHECK(fresh.state() != transport::SecureSessionState::kEstablished);
      break;
    }
  }
  CheckBalanced(slave.counters());
  CheckBalanced(master.counters());
  const bool already = slave.counters().count(SecureReceiveStatus::kSample) > 0;
  const auto r = slave.Receive(std::span(frame).first(frame_size), ++now, b, out);
  TELEOP_FUZZ_CHECK(r.status == (already ? SecureReceiveStatus::kReplayed : SecureReceiveStatus::kSample));
  return 0;
}
