#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "teleop/error.hpp"
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
  std::uint64_t segments = 0;      ///< Segments exchanged in segmented transfers (each way counted once).
  std::uint64_t aborts_sent = 0;   ///< Aborts this client sent (protocol errors, timeouts mid-transfer).
};

/// The server aborted a transfer (a teleop::Error carrying the abort code, so a caller can tell "object absent"
/// from a real failure).
class SdoAbortError : public Error {
 public:
  SdoAbortError(const std::string& what, std::uint32_t code) : Error(what), code_(code) {}
  std::uint32_t code() const noexcept { return code_; }

 private:
  std::uint32_t code_;
};

/// A blocking, set-up-only SDO client for one server (node): expedited and segmented transfers (CiA 301 §7.2.4.3).
/// Every call sends its requests on 0x600 + node, waits (Timebase::wait_ns) for each response on 0x580 + node,
/// retries timed-out attempts with exponential backoff (each timed-out attempt is aborted with 0x05040000, so a
/// server that began a segmented transfer is idle again; one that times out mid-way is restarted from its initiate),
/// and throws teleop::Error naming the object, the node and the decoded abort code or the timeout. A protocol error of
/// the server (a toggle bit that did not alternate, a command specifier that does not fit, more or fewer bytes than
/// indicated) is answered with an abort frame carrying the standard's code (0x05030000, 0x05040001, 0x06070010,
/// 0x05040005) and reported with it. Frames that are not its response are passed to `other_frames` (heartbeats, EMCY
/// arriving during set-up must not be lost). Never used in the control cycle.
class SdoClient {
 public:
  using FrameSink = std::function<void(const proto::can::CanFrame&)>;

  SdoClient(transport::CanPort& port, std::uint8_t node_id, SdoClientConfig config, Timebase timebase,
            FrameSink other_frames = {});

  /// Reads an object of 1..4 bytes (the server may answer expedited or segmented). `expected_size` 0 accepts any
  /// size; otherwise a different size is an error (an expedited answer without the size, 0x42, gives its low
  /// `expected_size` bytes).
  std::uint32_t Upload(std::uint16_t index, std::uint8_t subindex, std::uint8_t expected_size = 0);
  /// Writes `size` (1..4) bytes of `value` (expedited).
  void Download(std::uint16_t index, std::uint8_t subindex, std::uint32_t value, std::uint8_t size);
  /// Reads an object of any length (expedited or segmented, as the server chooses); more than `max_bytes` is
  /// aborted with 0x05040005 (out of memory) and an error.
  std::vector<std::uint8_t> UploadBytes(std::uint16_t index, std::uint8_t subindex, std::size_t max_bytes = 4096);
  /// A VISIBLE_STRING (0x1008 device name, 0x1009/0x100A versions): UploadBytes up to the first NUL.
  std::string UploadString(std::uint16_t index, std::uint8_t subindex, std::size_t max_bytes = 4096);
  /// Writes `data`: expedited for 1..4 bytes, segmented (size indicated) otherwise.
  void DownloadBytes(std::uint16_t index, std::uint8_t subindex, std::span<const std::uint8_t> data);

  const SdoClientCounters& counters() const noexcept { return counters_; }
  std::uint8_t node_id() const noexcept { return node_id_; }

 private:
  /// UploadBytes; `expedited_size_unknown` is set when the answer was expedited without the size (4 bytes taken).
  std::vector<std::uint8_t> UploadImpl(std::uint16_t index, std::uint8_t subindex, std::size_t max_bytes,
                                       bool& expedited_size_unknown);
  SdoMessage Transfer(const proto::can::CanFrame& request, std::uint16_t index, std::uint8_t subindex,
                      const char* what);
  /// The segment phase of an upload after its initiate response `initiate`; false when a segment timed out (the
  /// abort has been sent: the caller restarts).
  bool UploadSegments(const SdoMessage& initiate, std::uint16_t index, std::uint8_t subindex, std::size_t max_bytes,
                      std::vector<std::uint8_t>& out);
  bool DownloadSegments(std::uint16_t index, std::uint8_t subindex, std::span<const std::uint8_t> data);
  /// Sends one segment request and waits for its response; false on timeout. Throws on an abort from the server.
  bool ExchangeSegment(const proto::can::CanFrame& request, std::uint16_t index, std::uint8_t subindex,
                       const char* what, SdoMessage& response);
  /// Sends an abort for the transfer of index:subindex, then throws an Error with `message` and the code's text.
  [[noreturn]] void AbortTransfer(std::uint16_t index, std::uint8_t subindex, std::uint32_t code, const char* what,
                                  const std::string& message);
  void SendAbort(std::uint16_t index, std::uint8_t subindex, std::uint32_t code) noexcept;
  void Drain();

  transport::CanPort& port_;
  std::uint8_t node_id_;
  SdoClientConfig config_;
  Timebase timebase_;
  FrameSink other_frames_;
  SdoClientCounters counters_{};
  std::uint8_t last_command_ = 0;  ///< Byte 0 of the last segment response (for messages).
};

/// "0x6060:00" — for messages.
std::string FormatObject(std::uint16_t index, std::uint8_t subindex);

}  // namespace teleop::fieldbus::canopen
