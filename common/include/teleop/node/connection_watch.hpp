#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "teleop/node/cycle_sink.hpp"
#include "teleop/types.hpp"

namespace teleop::node {

/// What a process knows about reaching its peer: the link's counters while no usable sample came
/// (docs/troubleshooting.md, "The pair does not connect").
struct ConnectionFacts {
  Role role = Role::kMaster;
  std::string transport = "udp";  ///< link.transport: "udp", "can" or "emulated-can".
  std::string peer_address;       ///< "10.77.0.2:47002" on UDP; empty on CAN.
  bool authenticated = false;     ///< link.security.mode psk.
  std::uint64_t sent = 0;
  std::uint64_t received = 0;
  std::uint64_t accepted = 0;
  std::uint64_t rejected = 0;
  std::uint64_t handshakes_started = 0;  ///< Hellos sent (master) or answered (slave).
  std::uint64_t handshake_messages = 0;
  std::uint64_t sessions = 0;
  std::uint64_t bad_handshake_tag = 0;  ///< Handshakes refused: MAC wrong (another key).
  std::uint64_t insecure_refused = 0;   ///< Unauthenticated samples refused by an authenticated link.
  std::uint64_t bad_version = 0;        ///< Datagrams of another wire protocol version.
  std::uint64_t wrong_sender = 0;
  std::uint64_t unreachable = 0;  ///< Receive errors (UDP: ICMP port unreachable, nothing listens at the peer).
  std::uint64_t dof_mismatches = 0;
  std::uint8_t peer_protocol_version = 0;  ///< LinkCounters::peer_protocol_version.
  bool connected = false;                  ///< A usable sample of the peer arrived at some time in the run.
  double waited_s = 0.0;                   ///< Since the first cycle.
};

/// The facts from a link's counters (the rest of ConnectionFacts is the caller's).
void FillFromCounters(const transport::LinkCounters& counters, ConnectionFacts& facts) noexcept;

/// One line saying what this process waits for and what it sees ("waiting for the slave at 10.77.0.2:47002: 40
/// hellos sent, no answer (is it running? is the address right? a firewall? the same key?)"); "connected" once a
/// usable sample came. The run summary's "connection" line says the same.
std::string DescribeConnection(const ConnectionFacts& facts);

/// A sink that watches whether the peer ever became usable. In the cycle it only copies a few counters into atomics
/// (10 times a second); its own background thread prints DescribeConnection every `status_interval_s` while the peer
/// is not usable, and after `connect_timeout_s` without ever connecting calls `give_up` (ProcessMain stops the node).
/// Finish() writes the summary's `connection` and, after a give-up, the stop reason "connect timeout".
class ConnectionWatch final : public CycleSink {
 public:
  struct Config {
    ConnectionFacts base;            ///< Role, transport, peer address, security; counters are filled in.
    double rate_hz = 1000.0;         ///< The loop's, for the decimation.
    double status_interval_s = 2.0;  ///< 0: no status lines.
    double connect_timeout_s = 0.0;  ///< 0: wait for ever.
  };
  ConnectionWatch(Config config, std::function<void()> give_up);
  ~ConnectionWatch() override;
  ConnectionWatch(const ConnectionWatch&) = delete;
  ConnectionWatch& operator=(const ConnectionWatch&) = delete;

  void OnCycle(const CycleRecord& record) noexcept override;
  void Finish(RunSummary& summary) override;

  /// The newest facts the cycle published (any thread).
  ConnectionFacts Snapshot() const;
  bool gave_up() const noexcept { return gave_up_.load(std::memory_order_acquire); }

 private:
  void Watch();
  void StopThread();

  // The counters the cycle copies (relaxed: a status line may mix two cycles' values).
  enum Slot : std::uint8_t {
    kSent,
    kReceived,
    kAccepted,
    kRejected,
    kHandshakesStarted,
    kHandshakeMessages,
    kSessions,
    kBadHandshakeTag,
    kInsecureRefused,
    kBadVersion,
    kWrongSender,
    kUnreachable,
    kPeerVersion,
    kSlots,
  };
  Config config_;
  std::function<void()> give_up_;
  std::uint64_t decimation_ = 100;
  std::array<std::atomic<std::uint64_t>, kSlots> slots_{};
  std::atomic<std::uint64_t> waited_ns_{0};
  std::atomic<bool> started_{false};
  std::atomic<bool> connected_{false};
  std::atomic<bool> usable_now_{false};
  std::atomic<bool> gave_up_{false};
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;  ///< Guarded by mutex_.
  std::thread thread_;
};

}  // namespace teleop::node
