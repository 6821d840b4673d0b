#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "teleop/fieldbus/canopen_sdo.hpp"
#include "teleop/fieldbus/canopen_timebase.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::fieldbus::canopen {

/// Timeouts and retries of the set-up SDO client (the field notes: recovery after an emergency stop can time out on
/// SDO; retry with backoff and report).
struct SdoClientConfig {
  double timeout_ms = 50.0;          ///< Per attempt: request sent → response read (CiA 301 leaves it to the client).
  int retries = 3;                   ///< Attempts after the first one when a request times out (not when aborted).
  double backoff_initial_ms = 10.0;  ///< Wait before the first retry; doubled before each further one.
  double backoff_max_ms = 200.0;
};

/// What the SDO client counted.
struct SdoClientCounters {
  std::uint64_t requests = 0;      ///< Frames sent (retries included).
  std::uint64_t timeouts = 0;      ///< Attempts that got no response in time.
  std::uint64_t aborts = 0;        ///< Transfers the server aborted.
  std::uint64_t unexpected = 0;    ///< Responses for another object, unsupported kinds (segmented): ignored.
  std::uint64_t other_frames = 0;  ///< Non-SDO frames read while waiting (handed to the frame sink).
};

/// A blocking, set-up-only SDO client for expedited transfers to one server (node). Every call sends one request on
/// 0x600 + node, waits (Timebase::wait_ns) for the response on 0x580 + node, retries timed-out attempts with
/// exponential backoff, and throws teleop::Error naming the object, the node and the decoded abort code or the
/// timeout. Frames that are not its response are passed to `other_frames` (heartbeats, EMCY arriving during set-up
/// must not be lost). Never used in the control cycle.
class SdoClient {
 public:
  using FrameSink = std::function<void(const proto::can::CanFrame&)>;

  SdoClient(transport::CanPort& port, std::uint8_t node_id, SdoClientConfig config, Timebase timebase,
            FrameSink other_frames = {});

  /// Reads an object of 1..4 bytes. `expected_size` 0 accepts any size; otherwise a different size is an error.
  std::uint32_t Upload(std::uint16_t index, std::uint8_t subindex, std::uint8_t expected_size = 0);
  /// Writes `size` (1..4) bytes of `value`.
  void Download(std::uint16_t index, std::uint8_t subindex, std::uint32_t value, std::uint8_t size);

  const SdoClientCounters& counters() const noexcept { return counters_; }
  std::uint8_t node_id() const noexcept { return node_id_; }

 private:
  SdoMessage Transfer(const proto::can::CanFrame& request, std::uint16_t index, std::uint8_t subindex,
                      const char* what);

  transport::CanPort& port_;
  std::uint8_t node_id_;
  SdoClientConfig config_;
  Timebase timebase_;
  FrameSink other_frames_;
  SdoClientCounters counters_{};
};

/// "0x6060:00" — for messages.
std::string FormatObject(std::uint16_t index, std::uint8_t subindex);

}  // namespace teleop::fieldbus::canopen
