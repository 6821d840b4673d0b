#pragma once

// A host CAN port that passes everything through unless told to refuse the SYNC (0x080): a bus exchange that fails
// while every drive is fine. For the fieldbus devices' "a refused SYNC is named as the SYNC" tests.

#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "teleop/transport/can_port.hpp"

namespace teleop::test {

class SyncGate final : public transport::CanPort {
 public:
  /// Wraps `inner`, which the caller keeps alive.
  explicit SyncGate(transport::CanPort& inner) : inner_(&inner) {}
  /// Wraps and owns `inner` (a port factory's port).
  explicit SyncGate(std::unique_ptr<transport::CanPort> inner) : owned_(std::move(inner)), inner_(owned_.get()) {}

  transport::CanWriteStatus Write(const proto::can::CanFrame& frame) noexcept override {
    if (refuse_sync && frame.id == 0x080) return transport::CanWriteStatus::kBufferFull;
    return inner_->Write(frame);
  }
  bool Read(proto::can::CanFrame& frame) noexcept override { return inner_->Read(frame); }
  std::string Describe() const override { return inner_->Describe(); }
  bool WaitReadable(std::int64_t deadline_ns) noexcept override { return inner_->WaitReadable(deadline_ns); }
  std::int64_t now_ns() const noexcept override { return inner_->now_ns(); }
  std::int64_t receive_time_ns() const noexcept override { return inner_->receive_time_ns(); }

  bool refuse_sync = false;

 private:
  std::unique_ptr<transport::CanPort> owned_;
  transport::CanPort* inner_;
};

}  // namespace teleop::test
