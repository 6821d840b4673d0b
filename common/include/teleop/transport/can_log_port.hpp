#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "teleop/proto/can/can_frame.hpp"
#include "teleop/runtime/spsc_ring.hpp"
#include "teleop/transport/can_log.hpp"
#include "teleop/transport/can_port.hpp"

namespace teleop::transport {

/// A CanPort that records the frames its node puts on and reads from the bus (config `link.can.log_path`) as a
/// candump -L log (teleop/transport/can_log.hpp; readable by can-utils' canplayer and log2asc), without slow I/O in
/// the control cycle: Write/Read pass each frame to the wrapped port, and every frame written (status ok) or read
/// (data and error frames) is stamped with CLOCK_REALTIME and pushed into a preallocated lock-free ring. A writer
/// thread drains the ring into the file. A full ring drops the frame and counts it (dropped()); the log then lacks
/// it, the link does not. The file is opened at construction (set-up: throws teleop::Error when it cannot be).
class CandumpLogPort final : public CanPort {
 public:
  /// Frames the ring holds: 2 s of a 4-frame-per-cycle link at 1 kHz in each direction.
  static constexpr std::size_t kDefaultRingFrames = 16384;

  CandumpLogPort(std::unique_ptr<CanPort> inner, const std::string& path, std::string interface_name,
                 std::size_t ring_frames = kDefaultRingFrames);
  /// Stops the writer after it has written every frame still in the ring.
  ~CandumpLogPort() override;

  [[nodiscard]] CanWriteStatus Write(const proto::can::CanFrame& frame) noexcept override;
  [[nodiscard]] bool Read(proto::can::CanFrame& frame) noexcept override;
  /// The wrapped port's (the log does not delay or stamp what the link sees).
  [[nodiscard]] bool WaitReadable(std::int64_t deadline_ns) noexcept override {
    return inner_->WaitReadable(deadline_ns);
  }
  std::int64_t now_ns() const noexcept override { return inner_->now_ns(); }
  std::int64_t receive_time_ns() const noexcept override { return inner_->receive_time_ns(); }
  std::string Describe() const override;
  /// "candump log PATH: N frames logged, M dropped (ring full), K write errors". Logged: handed to the writer (all
  /// of them are in the file once the port is destroyed, less any write errors); the writer may still be behind.
  std::string Summary() const override;

  std::uint64_t logged() const noexcept { return logged_.load(std::memory_order_relaxed); }
  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }
  std::uint64_t written() const noexcept { return written_.load(std::memory_order_relaxed); }
  std::uint64_t write_errors() const noexcept { return write_errors_.load(std::memory_order_relaxed); }

 private:
  struct Record {
    proto::can::CanFrame frame;
    std::uint64_t time_ns;
  };
  void Log(const proto::can::CanFrame& frame) noexcept;
  void Drain();

  std::unique_ptr<CanPort> inner_;
  CandumpLogWriter writer_;
  runtime::SpscRing<Record> ring_;
  std::atomic<std::uint64_t> logged_{0};
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<std::uint64_t> written_{0};
  std::atomic<std::uint64_t> write_errors_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace teleop::transport
