#include "teleop/fieldbus/canopen_sdo_client.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::fieldbus::canopen {

namespace {

std::uint64_t ToNs(double ms) noexcept { return static_cast<std::uint64_t>(std::llround(std::max(0.0, ms) * 1e6)); }

/// How long to wait between two polls of the port while a response is awaited.
constexpr std::uint64_t kPollStep_ns = 100'000;

}  // namespace

std::string FormatObject(std::uint16_t index, std::uint8_t subindex) {
  return fmt::format("0x{:04X}:{:02X}", index, subindex);
}

SdoClient::SdoClient(transport::CanPort& port, std::uint8_t node_id, SdoClientConfig config, Timebase timebase,
                     FrameSink other_frames)
    : port_(port),
      node_id_(node_id),
      config_(config),
      timebase_(std::move(timebase)),
      other_frames_(std::move(other_frames)) {
  if (!IsValidNodeId(node_id)) throw Error(fmt::format("SDO client: node-ID {} is not 1..127", node_id));
  if (!(config_.timeout_ms > 0.0) || config_.retries < 0 || config_.backoff_initial_ms < 0.0 ||
      config_.backoff_max_ms < config_.backoff_initial_ms) {
    throw Error("SDO client: timeout_ms must be > 0, retries >= 0, 0 <= backoff_initial_ms <= backoff_max_ms");
  }
  if (!timebase_.now_ns || !timebase_.wait_ns) throw Error("SDO client: timebase without a clock or a wait");
}

std::uint32_t SdoClient::Upload(std::uint16_t index, std::uint8_t subindex, std::uint8_t expected_size) {
  const SdoMessage m = Transfer(EncodeSdoUploadRequest(node_id_, index, subindex), index, subindex, "read");
  if (m.kind != SdoMessage::Kind::kUploadResponse) {
    throw Error(fmt::format("SDO read of {} on node {}: the drive answered with a download response",
                            FormatObject(index, subindex), node_id_));
  }
  if (expected_size != 0 && m.size != expected_size) {
    throw Error(fmt::format("SDO read of {} on node {}: {} bytes, expected {}", FormatObject(index, subindex), node_id_,
                            m.size, expected_size));
  }
  return m.value;
}

void SdoClient::Download(std::uint16_t index, std::uint8_t subindex, std::uint32_t value, std::uint8_t size) {
  if (size < 1 || size > 4) {
    throw Error(fmt::format("SDO write of {}: {} bytes (expedited: 1..4)", FormatObject(index, subindex), size));
  }
  const SdoMessage m =
      Transfer(EncodeSdoDownloadRequest(node_id_, index, subindex, value, size), index, subindex, "write");
  if (m.kind != SdoMessage::Kind::kDownloadResponse) {
    throw Error(fmt::format("SDO write of {} on node {}: the drive answered with an upload response",
                            FormatObject(index, subindex), node_id_));
  }
}

SdoMessage SdoClient::Transfer(const proto::can::CanFrame& request, std::uint16_t index, std::uint8_t subindex,
                               const char* what) {
  const std::uint32_t response_id = cob::kSdoTx + node_id_;
  double backoff_ms = config_.backoff_initial_ms;
  for (int attempt = 0; attempt <= config_.retries; ++attempt) {
    if (attempt > 0) {
      timebase_.wait_ns(ToNs(backoff_ms));
      backoff_ms = std::min(config_.backoff_max_ms, backoff_ms * 2.0);
    }
    // A response left over from an earlier, timed-out attempt would be taken for this one: drain first.
    proto::can::CanFrame frame{};
    while (port_.Read(frame)) {
      if (!frame.error && frame.id == response_id) {
        ++counters_.unexpected;
      } else {
        ++counters_.other_frames;
        if (other_frames_) other_frames_(frame);
      }
    }
    const transport::CanWriteStatus status = port_.Write(request);
    if (status != transport::CanWriteStatus::kOk) {
      if (attempt < config_.retries) continue;
      throw Error(fmt::format("SDO {} of {} on node {}: the CAN port refused the request ({})", what,
                              FormatObject(index, subindex), node_id_, transport::ToString(status)));
    }
    ++counters_.requests;
    const std::uint64_t deadline = timebase_.now_ns() + ToNs(config_.timeout_ms);
    for (;;) {
      while (port_.Read(frame)) {
        SdoMessage m{};
        if (frame.error || frame.id != response_id || !DecodeSdoResponse(frame, m)) {
          ++counters_.other_frames;
          if (other_frames_) other_frames_(frame);
          continue;
        }
        if (m.index != index || m.subindex != subindex || m.kind == SdoMessage::Kind::kUnsupported) {
          ++counters_.unexpected;
          if (m.kind == SdoMessage::Kind::kUnsupported && m.index == index && m.subindex == subindex) {
            throw Error(fmt::format(
                "SDO {} of {} on node {}: the drive answered with a segmented/block transfer (command 0x{:02X}); "
                "only expedited transfers (1..4 bytes) are supported",
                what, FormatObject(index, subindex), node_id_, frame.data[0]));
          }
          continue;
        }
        if (m.kind == SdoMessage::Kind::kAbort) {
          ++counters_.aborts;
          throw Error(fmt::format("SDO {} of {} on node {} aborted: 0x{:08X} {}", what, FormatObject(index, subindex),
                                  node_id_, m.abort_code, DescribeSdoAbort(m.abort_code)));
        }
        return m;
      }
      if (timebase_.now_ns() >= deadline) break;
      timebase_.wait_ns(kPollStep_ns);
    }
    ++counters_.timeouts;
  }
  throw Error(
      fmt::format("SDO {} of {} on node {}: no response within {:g} ms, {} attempts (is the drive powered, "
                  "on this bus, with node-ID {}?)",
                  what, FormatObject(index, subindex), node_id_, config_.timeout_ms, config_.retries + 1, node_id_));
}

}  // namespace teleop::fieldbus::canopen
