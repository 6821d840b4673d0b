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
  bool size_unknown = false;
  std::vector<std::uint8_t> bytes = UploadImpl(index, subindex, 4, size_unknown);
  // An expedited answer without the size (e = 1, s = 0: "d contains unspecified number of bytes", CiA 301) holds
  // the object in its low bytes: a caller that knows the type takes that many.
  if (size_unknown && expected_size != 0 && expected_size < bytes.size()) bytes.resize(expected_size);
  if (bytes.empty()) {
    throw Error(
        fmt::format("SDO read of {} on node {}: the drive sent 0 bytes", FormatObject(index, subindex), node_id_));
  }
  if (expected_size != 0 && bytes.size() != expected_size) {
    throw Error(fmt::format("SDO read of {} on node {}: {} bytes, expected {}", FormatObject(index, subindex), node_id_,
                            bytes.size(), expected_size));
  }
  std::uint32_t value = 0;
  for (std::size_t i = bytes.size(); i > 0; --i) value = value << 8 | bytes[i - 1];
  return value;
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

std::vector<std::uint8_t> SdoClient::UploadBytes(std::uint16_t index, std::uint8_t subindex, std::size_t max_bytes) {
  bool size_unknown = false;
  return UploadImpl(index, subindex, max_bytes, size_unknown);
}

std::vector<std::uint8_t> SdoClient::UploadImpl(std::uint16_t index, std::uint8_t subindex, std::size_t max_bytes,
                                                bool& expedited_size_unknown) {
  expedited_size_unknown = false;
  double backoff_ms = config_.backoff_initial_ms;
  for (int attempt = 0;; ++attempt) {
    const SdoMessage m = Transfer(EncodeSdoUploadRequest(node_id_, index, subindex), index, subindex, "read");
    if (m.kind == SdoMessage::Kind::kUploadResponse) {
      expedited_size_unknown = !m.size_indicated;
      std::vector<std::uint8_t> bytes(m.size);
      for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(m.value >> (8 * i));
      return bytes;
    }
    if (m.kind != SdoMessage::Kind::kUploadInitiateSegmented) {
      throw Error(fmt::format("SDO read of {} on node {}: the drive answered with a download response",
                              FormatObject(index, subindex), node_id_));
    }
    std::vector<std::uint8_t> bytes;
    if (UploadSegments(m, index, subindex, max_bytes, bytes)) return bytes;
    if (attempt >= config_.retries) {
      throw Error(
          fmt::format("SDO read of {} on node {}: a segment got no response within {:g} ms, {} attempts "
                      "(aborted with 0x{:08X} {})",
                      FormatObject(index, subindex), node_id_, config_.timeout_ms, attempt + 1, sdo_abort::kTimeout,
                      DescribeSdoAbort(sdo_abort::kTimeout)));
    }
    timebase_.wait_ns(ToNs(backoff_ms));
    backoff_ms = std::min(config_.backoff_max_ms, backoff_ms * 2.0);
  }
}

std::string SdoClient::UploadString(std::uint16_t index, std::uint8_t subindex, std::size_t max_bytes) {
  const std::vector<std::uint8_t> bytes = UploadBytes(index, subindex, max_bytes);
  std::string s(bytes.begin(), bytes.end());
  const std::size_t nul = s.find('\0');
  if (nul != std::string::npos) s.resize(nul);
  return s;
}

void SdoClient::DownloadBytes(std::uint16_t index, std::uint8_t subindex, std::span<const std::uint8_t> data) {
  if (!data.empty() && data.size() <= 4) {
    std::uint32_t value = 0;
    for (std::size_t i = data.size(); i > 0; --i) value = value << 8 | data[i - 1];
    Download(index, subindex, value, static_cast<std::uint8_t>(data.size()));
    return;
  }
  if (data.size() > 0xFFFF'FFFFu) throw Error("SDO write: more than 2^32 - 1 bytes");
  double backoff_ms = config_.backoff_initial_ms;
  for (int attempt = 0;; ++attempt) {
    const SdoMessage m =
        Transfer(EncodeSdoInitiateDownloadSegmented(node_id_, index, subindex, static_cast<std::uint32_t>(data.size())),
                 index, subindex, "write");
    if (m.kind != SdoMessage::Kind::kDownloadResponse) {
      throw Error(fmt::format("SDO write of {} on node {}: the drive answered with an upload response",
                              FormatObject(index, subindex), node_id_));
    }
    if (DownloadSegments(index, subindex, data)) return;
    if (attempt >= config_.retries) {
      throw Error(
          fmt::format("SDO write of {} on node {}: a segment got no response within {:g} ms, {} attempts "
                      "(aborted with 0x{:08X} {})",
                      FormatObject(index, subindex), node_id_, config_.timeout_ms, attempt + 1, sdo_abort::kTimeout,
                      DescribeSdoAbort(sdo_abort::kTimeout)));
    }
    timebase_.wait_ns(ToNs(backoff_ms));
    backoff_ms = std::min(config_.backoff_max_ms, backoff_ms * 2.0);
  }
}

bool SdoClient::UploadSegments(const SdoMessage& initiate, std::uint16_t index, std::uint8_t subindex,
                               std::size_t max_bytes, std::vector<std::uint8_t>& out) {
  const bool indicated = initiate.size_indicated;
  const std::size_t size = initiate.value;
  if (indicated && size > max_bytes) {
    AbortTransfer(index, subindex, sdo_abort::kOutOfMemory, "read",
                  fmt::format("the drive indicated {} bytes, at most {} accepted", size, max_bytes));
  }
  out.clear();
  out.reserve(indicated ? size : 64);
  bool toggle = false;
  for (int n = 1;; ++n) {
    SdoMessage r{};
    if (!ExchangeSegment(EncodeSdoUploadSegmentRequest(node_id_, toggle), index, subindex, "read", r)) return false;
    if (r.kind != SdoMessage::Kind::kUploadSegmentResponse) {
      AbortTransfer(
          index, subindex, sdo_abort::kBadCommand, "read",
          fmt::format("the drive answered upload segment request {} with command 0x{:02X}", n, last_command_));
    }
    if (r.toggle != toggle) {
      AbortTransfer(
          index, subindex, sdo_abort::kToggleBit, "read",
          fmt::format("upload segment {} came with toggle bit {}, expected {}", n, r.toggle ? 1 : 0, toggle ? 1 : 0));
    }
    if (out.size() + r.segment_size > max_bytes) {
      AbortTransfer(index, subindex, sdo_abort::kOutOfMemory, "read",
                    fmt::format("more than {} bytes in segment {}", max_bytes, n));
    }
    if (indicated && out.size() + r.segment_size > size) {
      AbortTransfer(index, subindex, sdo_abort::kLengthMismatch, "read",
                    fmt::format("segment {} goes past the {} bytes indicated", n, size));
    }
    out.insert(out.end(), r.segment.begin(), r.segment.begin() + r.segment_size);
    ++counters_.segments;
    if (r.last) {
      if (indicated && out.size() != size) {
        AbortTransfer(index, subindex, sdo_abort::kLengthMismatch, "read",
                      fmt::format("{} bytes received, {} indicated", out.size(), size));
      }
      return true;
    }
    toggle = !toggle;
  }
}

bool SdoClient::DownloadSegments(std::uint16_t index, std::uint8_t subindex, std::span<const std::uint8_t> data) {
  bool toggle = false;
  std::size_t offset = 0;
  int n = 1;
  do {
    const std::size_t chunk = std::min(kSdoSegmentBytes, data.size() - offset);
    const bool last = offset + chunk == data.size();
    SdoMessage r{};
    if (!ExchangeSegment(EncodeSdoDownloadSegment(node_id_, toggle, data.subspan(offset, chunk), last), index, subindex,
                         "write", r)) {
      return false;
    }
    if (r.kind != SdoMessage::Kind::kDownloadSegmentResponse) {
      AbortTransfer(index, subindex, sdo_abort::kBadCommand, "write",
                    fmt::format("the drive answered download segment {} with command 0x{:02X}", n, last_command_));
    }
    if (r.toggle != toggle) {
      AbortTransfer(index, subindex, sdo_abort::kToggleBit, "write",
                    fmt::format("the response to download segment {} came with toggle bit {}, expected {}", n,
                                r.toggle ? 1 : 0, toggle ? 1 : 0));
    }
    ++counters_.segments;
    offset += chunk;
    toggle = !toggle;
    ++n;
  } while (offset < data.size());
  return true;
}

bool SdoClient::ExchangeSegment(const proto::can::CanFrame& request, std::uint16_t index, std::uint8_t subindex,
                                const char* what, SdoMessage& response) {
  const std::uint32_t response_id = cob::kSdoTx + node_id_;
  const transport::CanWriteStatus status = port_.Write(request);
  if (status != transport::CanWriteStatus::kOk) {
    AbortTransfer(index, subindex, sdo_abort::kGeneral, what,
                  fmt::format("the CAN port refused a segment ({})", transport::ToString(status)));
  }
  ++counters_.requests;
  const std::uint64_t deadline = timebase_.now_ns() + ToNs(config_.timeout_ms);
  proto::can::CanFrame frame{};
  for (;;) {
    while (port_.Read(frame)) {
      SdoMessage m{};
      if (frame.error || frame.id != response_id || !DecodeSdoResponse(frame, m)) {
        ++counters_.other_frames;
        if (other_frames_) other_frames_(frame);
        continue;
      }
      if (m.kind == SdoMessage::Kind::kAbort) {
        ++counters_.aborts;
        throw SdoAbortError(
            fmt::format("SDO {} of {} on node {} aborted during the segmented transfer: 0x{:08X} {}", what,
                        FormatObject(index, subindex), node_id_, m.abort_code, DescribeSdoAbort(m.abort_code)),
            m.abort_code);
      }
      last_command_ = frame.data[0];
      response = m;
      return true;
    }
    if (timebase_.now_ns() >= deadline) break;
    timebase_.wait_ns(kPollStep_ns);
  }
  ++counters_.timeouts;
  SendAbort(index, subindex, sdo_abort::kTimeout);
  return false;
}

void SdoClient::SendAbort(std::uint16_t index, std::uint8_t subindex, std::uint32_t code) noexcept {
  if (port_.Write(EncodeSdoAbort(cob::kSdoRx + node_id_, index, subindex, code)) == transport::CanWriteStatus::kOk) {
    ++counters_.aborts_sent;
  }
}

void SdoClient::AbortTransfer(std::uint16_t index, std::uint8_t subindex, std::uint32_t code, const char* what,
                              const std::string& message) {
  SendAbort(index, subindex, code);
  throw Error(fmt::format("SDO {} of {} on node {}: {}; aborted with 0x{:08X} {}", what, FormatObject(index, subindex),
                          node_id_, message, code, DescribeSdoAbort(code)));
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
        const bool initiate_answer =
            m.kind == SdoMessage::Kind::kUploadResponse || m.kind == SdoMessage::Kind::kDownloadResponse ||
            m.kind == SdoMessage::Kind::kUploadInitiateSegmented || m.kind == SdoMessage::Kind::kAbort;
        if (m.index != index || m.subindex != subindex || !initiate_answer) {
          ++counters_.unexpected;
          if (m.kind == SdoMessage::Kind::kUnsupported && m.index == index && m.subindex == subindex) {
            AbortTransfer(index, subindex, sdo_abort::kBadCommand, what,
                          fmt::format("the drive answered with command 0x{:02X} (a block transfer or a reserved "
                                      "specifier; expedited and segmented transfers are supported)",
                                      frame.data[0]));
          }
          continue;
        }
        if (m.kind == SdoMessage::Kind::kAbort) {
          ++counters_.aborts;
          throw SdoAbortError(
              fmt::format("SDO {} of {} on node {} aborted: 0x{:08X} {}", what, FormatObject(index, subindex), node_id_,
                          m.abort_code, DescribeSdoAbort(m.abort_code)),
              m.abort_code);
        }
        return m;
      }
      if (timebase_.now_ns() >= deadline) break;
      timebase_.wait_ns(kPollStep_ns);
    }
    ++counters_.timeouts;
    // End whatever the server may have begun (a segmented transfer whose initiate answer was lost would make it
    // refuse the next initiate): CiA 301 lets either side abort, and stacks abort a timed-out request (0x05040000).
    SendAbort(index, subindex, sdo_abort::kTimeout);
  }
  throw Error(
      fmt::format("SDO {} of {} on node {}: no response within {:g} ms, {} attempts (is the drive powered, "
                  "on this bus, with node-ID {}?)",
                  what, FormatObject(index, subindex), node_id_, config_.timeout_ms, config_.retries + 1, node_id_));
}

}  // namespace teleop::fieldbus::canopen
