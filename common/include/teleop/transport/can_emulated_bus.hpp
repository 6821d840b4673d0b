#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "teleop/proto/can/bus_load.hpp"
#include "teleop/proto/can/can_frame.hpp"
#include "teleop/transport/can_filter.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::transport {

struct EmulatedCanBusConfig {
  double nominal_bitrate_bit_per_s = 1'000'000.0;
  double data_bitrate_bit_per_s = 5'000'000.0;
  /// Fraction of bus time the attached nodes get (the rest models other traffic): a frame occupies
  /// frame_time / load_ceiling. 1.0 = the bus is ours alone.
  double load_ceiling = 1.0;
  int tx_queue_frames = 32;   ///< Per node; a full queue refuses frames (kBufferFull), like a socket's ENOBUFS.
  int rx_queue_frames = 256;  ///< Per node; overflow drops the frame and counts rx_overflows.
};

/// A CAN bus in software (docs/can.md, "Emulated bus"). Every frame pending at any node competes for the bus;
/// the lowest arbitration identifier wins (11-bit before 29-bit with the same base identifier; equal identifiers
/// in submission order), occupies the bus for its worst-case-stuffing frame time at the configured bit rates, and
/// is delivered to every other node when its transmission ends. Fault confinement as ISO 11898-1: a destroyed
/// transmission costs the sender TEC += 8 (warning at 96, error-passive at 128, bus-off at 256) and every node
/// reads an error frame; a success costs TEC -= 1.
///
/// Time comes from `clock` (ns, monotonic, non-decreasing); the bus advances lazily whenever it is used. One thread
/// uses a bus (tests, simulations that step both ends in one loop, and the teleop-canbus daemon); two processes
/// share one through the daemon. No allocation after AddNode().
class EmulatedCanBus {
 public:
  using Clock = std::function<std::uint64_t()>;
  /// Blocks until the bus clock reads at least `until_ns` (a port's WaitReadable sleeps in it). The default
  /// sleeps on CLOCK_MONOTONIC, the steady clock's; a test on its own clock sets one that advances that clock.
  using Sleeper = std::function<void(std::uint64_t until_ns)>;
  /// steady_clock in ns.
  static std::uint64_t SteadyNow_ns() noexcept;

  explicit EmulatedCanBus(const EmulatedCanBusConfig& config, Clock clock = &SteadyNow_ns);
  ~EmulatedCanBus();
  EmulatedCanBus(const EmulatedCanBus&) = delete;
  EmulatedCanBus& operator=(const EmulatedCanBus&) = delete;

  /// Attaches a node (set-up only). Returns its index.
  int AddNode();
  /// A CanPort for node `node` that reads every frame; the bus must outlive it.
  std::unique_ptr<CanPort> MakePort(int node);
  /// A CanPort for node `node` that reads what a SocketCAN socket with `options` would (Accepts); frames it does
  /// not accept are discarded when read. FD frames are refused on write unless options.fd.
  std::unique_ptr<CanPort> MakePort(int node, CanReceiveOptions options);

  [[nodiscard]] CanWriteStatus Submit(int node, const proto::can::CanFrame& frame) noexcept;
  [[nodiscard]] bool Receive(int node, proto::can::CanFrame& frame) noexcept;
  /// The same, with the bus time at which the frame reached the node (the end of its transmission).
  [[nodiscard]] bool Receive(int node, proto::can::CanFrame& frame, std::uint64_t& receive_ns) noexcept;
  /// Advances the bus; true when `node` has a frame to read.
  [[nodiscard]] bool Pending(int node) noexcept;
  /// Replaces the sleeper (set-up only; see Sleeper).
  void SetSleeper(Sleeper sleeper);
  /// Sleeps with the sleeper until the bus clock reads `until_ns` (no-op when it already does).
  void SleepUntil(std::uint64_t until_ns) noexcept;
  /// Advances the bus to clock(): finishes every transmission that ended by then.
  void Run() noexcept;
  /// When the next transmission in progress or due ends (ns on the bus clock); UINT64_MAX when idle.
  std::uint64_t NextEvent_ns() const noexcept;

  /// Destroys the next `count` transmissions with an error frame (they are retried, as on a real bus).
  void InjectErrors(int count) noexcept;
  /// Puts `node` bus-off now: its transmit queue is flushed, it reads a bus-off error frame, Submit refuses.
  void ForceBusOff(int node) noexcept;
  /// Restarts a bus-off node (error counters 0); it reads a "restarted" error frame.
  void Restart(int node) noexcept;

  struct Stats {
    std::uint64_t frames_delivered = 0;  ///< Successful transmissions.
    std::uint64_t error_frames = 0;      ///< Destroyed transmissions.
    std::uint64_t busy_ns = 0;           ///< Bus time used (frames, error frames, ceiling share).
    std::uint64_t rx_overflows = 0;
    std::uint64_t tx_refused = 0;  ///< Submit refused: queue full or bus-off.
  };
  const Stats& stats() const noexcept { return stats_; }
  int node_count() const noexcept;
  int transmit_error_counter(int node) const noexcept;
  bool is_bus_off(int node) const noexcept;
  std::uint64_t now_ns() const { return clock_(); }
  /// Time a frame occupies this bus (worst-case stuffing, before the load ceiling).
  double FrameTime_s(const proto::can::CanFrame& frame) const noexcept;

 private:
  struct Node;
  struct InFlight {
    bool active = false;
    bool destroyed = false;
    int node = 0;
    std::uint64_t entry = 0;  ///< Submission number of the frame on the wire.
    std::uint64_t end_ns = 0;
    proto::can::CanFrame frame{};
  };
  void Deliver(int node, const proto::can::CanFrame& frame, std::uint64_t time_ns) noexcept;
  void DeliverError(int node, std::uint32_t error_class, std::uint8_t controller, std::uint64_t time_ns) noexcept;
  void Finish() noexcept;
  bool StartNext(std::uint64_t now) noexcept;

  EmulatedCanBusConfig config_;
  proto::can::CanBitrates rates_;
  Clock clock_;
  Sleeper sleeper_;
  std::vector<Node> nodes_;
  InFlight in_flight_{};
  std::uint64_t bus_free_ns_ = 0;
  std::uint64_t next_entry_ = 0;
  int errors_to_inject_ = 0;
  Stats stats_{};
};

}  // namespace teleop::transport
