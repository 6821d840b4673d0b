#pragma once

// The host's heartbeat on a CAN bus (CiA 301 heartbeat producer, COB-ID 0x700 + node-ID, one byte: the NMT state):
// one per bus, not per drive, for the drives whose consumer (0x1016) watches the host. A drive's consumer fires (EMCY
// 0x8130, its fault reaction) when no heartbeat of the consumed node arrives within its time, so a host that dies
// leaves its drives in their safe state.
//
// Service(now) sends it when due, from the cycle and from every set-up wait, so the heartbeat flows as long as the
// host is running its set-up or its loop and stops when both stop.

#include <cstdint>

#include "teleop/fieldbus/canopen_frames.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::fieldbus::canopen {

struct HeartbeatProducerCounters {
  std::uint64_t sent = 0;
  std::uint64_t write_failures = 0;  ///< The port refused the heartbeat (buffer full, bus-off, error).
};

/// The consumer heartbeat time entry of 0x1016 sub n (CiA 301): bits 16..23 the consumed node-ID, bits 0..15 the
/// time in ms (bits 24..31 reserved, 0). `time_ms` 0 switches the entry off.
constexpr std::uint32_t ConsumerHeartbeatEntry(std::uint8_t node_id, std::uint16_t time_ms) noexcept {
  return (std::uint32_t{node_id} << 16) | time_ms;
}

class HeartbeatProducer {
 public:
  /// `port` must outlive the producer. `node_id` 1..127, `period_ms` > 0 (0x1017 of the host); throws
  /// teleop::Error otherwise.
  HeartbeatProducer(transport::CanPort& port, std::uint8_t node_id, double period_ms);

  /// Sends the heartbeat (NMT state Operational) when a period has passed since the last one (the first at once).
  /// Non-blocking, no allocation. kOk when nothing was due; failures are counted (and retried at the next call).
  [[nodiscard]] transport::CanWriteStatus Service(std::uint64_t now_ns) noexcept;
  /// Sends one now and restarts the period from `now_ns`.
  [[nodiscard]] transport::CanWriteStatus SendNow(std::uint64_t now_ns) noexcept;

  std::uint8_t node_id() const noexcept { return node_id_; }
  const HeartbeatProducerCounters& counters() const noexcept { return counters_; }

 private:
  transport::CanPort& port_;
  std::uint8_t node_id_;
  std::uint64_t period_ns_;
  std::uint64_t next_ns_ = 0;
  bool started_ = false;
  HeartbeatProducerCounters counters_{};
};

}  // namespace teleop::fieldbus::canopen
