#include "teleop/transport/can_log_port.hpp"

#include <fmt/format.h>

#include <chrono>
#include <ctime>
#include <utility>

#include "teleop/runtime/background_thread.hpp"

namespace teleop::transport {

namespace {

std::uint64_t RealtimeNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);  // vDSO: no system call, no allocation
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

}  // namespace

CandumpLogPort::CandumpLogPort(std::unique_ptr<CanPort> inner, const std::string& path, std::string interface_name,
                               std::size_t ring_frames)
    : inner_(std::move(inner)), writer_(path, std::move(interface_name)), ring_(ring_frames) {
  thread_ = std::thread([this] {
    runtime::BecomeBackgroundThread("teleop-candump");
    while (!stop_.load(std::memory_order_acquire)) {
      Drain();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    Drain();
  });
}

CandumpLogPort::~CandumpLogPort() {
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

void CandumpLogPort::Drain() {
  Record record{};
  bool any = false;
  while (ring_.TryPop(record)) {
    any = true;
    if (writer_.Write(record.frame, record.time_ns)) {
      written_.fetch_add(1, std::memory_order_relaxed);
    } else {
      write_errors_.fetch_add(1, std::memory_order_relaxed);
    }
  }
  if (any) writer_.Flush();
}

void CandumpLogPort::Log(const proto::can::CanFrame& frame) noexcept {
  if (ring_.TryPush(Record{frame, RealtimeNs()})) {
    logged_.fetch_add(1, std::memory_order_relaxed);
  } else {
    dropped_.fetch_add(1, std::memory_order_relaxed);
  }
}

CanWriteStatus CandumpLogPort::Write(const proto::can::CanFrame& frame) noexcept {
  const CanWriteStatus status = inner_->Write(frame);
  if (status == CanWriteStatus::kOk) Log(frame);
  return status;
}

bool CandumpLogPort::Read(proto::can::CanFrame& frame) noexcept {
  if (!inner_->Read(frame)) return false;
  Log(frame);
  return true;
}

std::string CandumpLogPort::Describe() const { return inner_->Describe() + ", candump log " + writer_.path(); }

std::string CandumpLogPort::Summary() const {
  return fmt::format("candump log {}: {} frames logged, {} dropped (ring full), {} write errors", writer_.path(),
                     logged(), dropped(), write_errors());
}

}  // namespace teleop::transport
