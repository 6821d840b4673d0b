#pragma once

// The SYNC producer of a CAN bus (CiA 301 SYNC service, object 0x1005 bit 30): one per bus, not per drive. Every
// drive on the bus applies the RPDO it last received when the SYNC arrives (synchronous PDOs, transmission type 1)
// and samples its TPDOs on it, so the SYNC of a cycle must leave after every drive's RPDO of the previous cycle.
//
// Why apart from the drives: a SYNC queued right after one drive's RPDO (Cia402DriveConfig::produce_sync) can win
// arbitration (0x080 is the lowest PDO-relevant identifier) over RPDOs still pending at that moment, including
// another drive's or the producer's own; that drive then applies its torque one SYNC later. The device sends the
// SYNC once per cycle at a fixed point where the previous cycle's RPDOs have long left: the start of its cycle,
// after draining the TPDOs of the previous SYNC (docs/cia402.md, "SYNC on a bus with several drives").

#include <cstdint>

#include "teleop/fieldbus/canopen_frames.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::fieldbus::canopen {

struct SyncProducerCounters {
  std::uint64_t sent = 0;
  std::uint64_t write_failures = 0;  ///< The port refused the SYNC (buffer full, bus-off, error).
};

class SyncProducer {
 public:
  /// `port` must outlive the producer. `cob_id` (0x1005 bits 0..10): 0x080 by default; must be an 11-bit identifier
  /// other than 0x000 (NMT); throws teleop::Error otherwise.
  explicit SyncProducer(transport::CanPort& port, std::uint32_t cob_id = cob::kSync);

  /// Cycle: sends one SYNC (no counter byte). Non-blocking, no allocation. The port's status; failures are counted.
  [[nodiscard]] transport::CanWriteStatus Send() noexcept;

  std::uint32_t cob_id() const noexcept { return cob_id_; }
  const SyncProducerCounters& counters() const noexcept { return counters_; }

 private:
  transport::CanPort& port_;
  std::uint32_t cob_id_;
  SyncProducerCounters counters_{};
};

}  // namespace teleop::fieldbus::canopen
