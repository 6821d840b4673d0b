#include "teleop/transport/can_link.hpp"

#include <fmt/format.h>

#include <utility>

#include "../sample_intake.hpp"
#include "teleop/error.hpp"

namespace teleop::transport {

using proto::DecodeStatus;
using proto::can::FrameStatus;

const char* ToString(CanWriteStatus status) noexcept {
  switch (status) {
    case CanWriteStatus::kOk:
      return "ok";
    case CanWriteStatus::kBufferFull:
      return "buffer_full";
    case CanWriteStatus::kBusOff:
      return "bus_off";
    case CanWriteStatus::kError:
      return "error";
  }
  return "invalid";
}

namespace {

DecodeStatus ReasonOf(FrameStatus status) noexcept {
  switch (status) {
    case FrameStatus::kUnknownId:
      return DecodeStatus::kBadMagic;
    case FrameStatus::kBadFormat:
      return DecodeStatus::kBadType;
    case FrameStatus::kBadLength:
      return DecodeStatus::kBadLength;
    case FrameStatus::kCounterMismatch:
      return DecodeStatus::kBadCrc;
    case FrameStatus::kNonFinite:
      return DecodeStatus::kNonFinite;
    case FrameStatus::kOldLayout:
      return DecodeStatus::kBadVersion;  // the peer runs CAN layout 1 (an older build)
    default:
      return DecodeStatus::kOutOfRange;  // reserved bits, duplicate frame
  }
}

proto::can::CanWireFormat Checked(const proto::can::CanWireFormat& format) {
  const proto::can::FormatStatus status = proto::can::CheckFormat(format);
  if (status != proto::can::FormatStatus::kOk) {
    throw Error(
        std::string("CAN link: ") + proto::can::ToString(status) + " (dof " + std::to_string(format.dof) +
        fmt::format(", identifiers 0x{:X} / 0x{:X}", format.master_to_slave_base_id, format.slave_to_master_base_id) +
        (format.extended_id ? ", 29-bit)" : ", 11-bit)"));
  }
  return format;
}

}  // namespace

CanLink::CanLink(const proto::can::CanWireFormat& format, proto::SenderRole local_role, std::unique_ptr<CanPort> port,
                 std::string description)
    : format_(Checked(format)),
      local_role_(local_role),
      port_(std::move(port)),
      description_(std::move(description)),
      assembler_(format_, proto::PeerOf(local_role)),
      intake_(std::make_unique<detail::SampleIntake>(proto::PeerOf(local_role))) {
  if (!port_) throw Error("CAN link: no port");
}

CanLink::~CanLink() = default;

bool CanLink::Send(const proto::SampleMessage& message) noexcept {
  if (bus_off_) {
    ++can_.tx_refused_bus_off;
    ++counters_.send_errors;
    return false;
  }
  proto::SampleMessage m = message;
  m.sender = local_role_;
  const proto::can::EncodeResult r = proto::can::EncodeCycle(m, format_, tx_frames_);
  if (r.frames == 0) {  // dof differs from the configured one
    ++counters_.send_errors;
    return false;
  }
  can_.tx_saturated_fields += static_cast<std::uint64_t>(r.saturated);
  can_.tx_non_finite_fields += static_cast<std::uint64_t>(r.non_finite);
  for (int i = 0; i < r.frames; ++i) {
    const CanWriteStatus status = port_->Write(tx_frames_[static_cast<std::size_t>(i)]);
    if (status != CanWriteStatus::kOk) {
      if (status == CanWriteStatus::kBufferFull) ++can_.tx_buffer_full;
      if (status == CanWriteStatus::kBusOff) ++can_.tx_refused_bus_off;
      ++counters_.send_errors;
      return false;  // the peer sees a partial cycle and drops it
    }
    ++can_.frames_sent;
  }
  ++counters_.sent;
  return true;
}

void CanLink::Reject(DecodeStatus reason) noexcept { intake_->Reject(reason, counters_); }

void CanLink::CountAbandoned() noexcept {
  const std::uint64_t abandoned = assembler_.abandoned_partial_cycles();
  for (; abandoned_seen_ < abandoned; ++abandoned_seen_) {
    ++can_.partial_cycles;
    Reject(DecodeStatus::kTooShort);
  }
}

bool CanLink::OfferCycle(proto::SampleMessage& sample) noexcept {
  const SequenceTracker& tracker = intake_->tracker();
  const auto counter = static_cast<std::uint8_t>(sample.sequence);
  sample.sequence = tracker.has_any() ? proto::can::ExtendCounter(tracker.newest(), counter) : counter;
  if (intake_->OfferDecoded(sample, counters_) == SequenceTracker::Verdict::kNewer) {
    consecutive_old_ = 0;
    return true;
  }
  // A 4-bit counter cannot tell "8 or more cycles lost" or "the peer restarted" from "stale": after a few stale or
  // repeated cycles in a row, start tracking afresh (the next cycle is accepted).
  if (++consecutive_old_ >= kResyncAfter) {
    intake_->ResetTracker();
    consecutive_old_ = 0;
    ++can_.resyncs;
  }
  return false;
}

void CanLink::OpenDrain() noexcept {
  if (drain_open_) return;
  intake_->Begin();
  drain_open_ = true;
}

void CanLink::Drain() noexcept {
  for (int i = 0; i < kMaxFramesPerPoll; ++i) {
    if (!port_->Read(rx_frame_)) break;
    if (rx_frame_.error) {
      HandleErrorFrame(rx_frame_);
      continue;
    }
    ++can_.frames_received;
    const FrameStatus status = assembler_.Push(rx_frame_, scratch_);
    ++can_.frames_by_status[static_cast<std::size_t>(status)];
    CountAbandoned();
    if (status == FrameStatus::kComplete) {
      if (OfferCycle(scratch_)) {
        const std::int64_t stamped = port_->receive_time_ns();
        pending_receive_time_ns_ = stamped > 0 ? stamped : port_->now_ns();
      }
    } else if (status != FrameStatus::kPending) {
      Reject(ReasonOf(status));
    }
  }
}

bool CanLink::Poll(proto::SampleMessage& newest) noexcept {
  OpenDrain();
  Drain();
  assembler_.Tick();
  CountAbandoned();
  drain_open_ = false;
  if (!intake_->Finish(newest, counters_)) return false;
  newest_receive_time_ns_ = pending_receive_time_ns_;
  return true;
}

bool CanLink::WaitReadable(std::int64_t deadline_ns) noexcept {
  OpenDrain();
  for (;;) {
    Drain();
    if (intake_->has_pending()) return true;
    if (port_->now_ns() >= deadline_ns) return false;
    if (!port_->WaitReadable(deadline_ns)) return false;
  }
}

void CanLink::HandleErrorFrame(const proto::can::CanFrame& frame) noexcept {
  using namespace proto::can;
  ++counters_.bus_errors;
  ++can_.error_frames;
  const std::uint32_t c = frame.error_class;
  if ((c & kErrBusOff) != 0) {
    ++can_.bus_off;
    bus_off_ = true;
  }
  if ((c & kErrRestarted) != 0) {
    ++can_.restarts;
    bus_off_ = false;
  }
  if ((c & kErrController) != 0) {
    const std::uint8_t d = frame.data[1];
    if ((d & (kCtrlRxPassive | kCtrlTxPassive)) != 0) ++can_.error_passive;
    if ((d & (kCtrlRxWarning | kCtrlTxWarning)) != 0) ++can_.error_warning;
    if ((d & (kCtrlRxOverflow | kCtrlTxOverflow)) != 0) ++can_.controller_overflow;
  }
  if ((c & (kErrProtocol | kErrBusError)) != 0) ++can_.protocol_errors;
  if ((c & kErrNoAck) != 0) ++can_.no_ack;
  if ((c & kErrTxTimeout) != 0) ++can_.tx_timeouts;
  if ((c & kErrLostArbitration) != 0) ++can_.lost_arbitration;
  if ((c & kErrTransceiver) != 0) ++can_.transceiver;
}

std::string CanLink::Describe() const {
  std::string text =
      fmt::format("can {} ({}, {} DOF, {} 0x{:X} -> peer 0x{:X}", port_->Describe(), format_.fd ? "FD" : "classic",
                  format_.dof, proto::ToString(local_role_), proto::can::BaseIdOf(format_, local_role_),
                  proto::can::BaseIdOf(format_, proto::PeerOf(local_role_)));
  text += format_.extended_id ? ", 29-bit)" : ", 11-bit)";
  if (!description_.empty()) text += "; " + description_;
  return text;
}

std::string CanLink::Summary() const {
  std::string by_status;
  for (std::size_t i = 0; i < can_.frames_by_status.size(); ++i) {
    if (can_.frames_by_status[i] == 0) continue;
    if (!by_status.empty()) by_status += ", ";
    by_status += fmt::format("{} {}", proto::can::ToString(static_cast<FrameStatus>(i)), can_.frames_by_status[i]);
  }
  std::string text = fmt::format(
      "CAN frames sent {}, received {} ({}); partial cycles {}, resyncs {}; tx: saturated fields {}, non-finite "
      "fields {}, buffer full {}, refused bus-off {}; error frames {} (bus-off {}, error-passive {}, warning {}, "
      "protocol {}, no-ack {}, overflow {}, tx-timeout {}, restarted {}){}",
      can_.frames_sent, can_.frames_received, by_status.empty() ? "none" : by_status, can_.partial_cycles, can_.resyncs,
      can_.tx_saturated_fields, can_.tx_non_finite_fields, can_.tx_buffer_full, can_.tx_refused_bus_off,
      can_.error_frames, can_.bus_off, can_.error_passive, can_.error_warning, can_.protocol_errors, can_.no_ack,
      can_.controller_overflow, can_.tx_timeouts, can_.restarts, bus_off_ ? "; LINK FAULT: bus-off" : "");
  if (const std::string port = port_->Summary(); !port.empty()) text += "; " + port;  // e.g. its candump log
  return text;
}

}  // namespace teleop::transport
