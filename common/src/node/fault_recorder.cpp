#include "teleop/node/fault_recorder.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <system_error>

#include "teleop/runtime/background_thread.hpp"

namespace teleop::node {

namespace {

std::string FileWord(Outage kind) {
  std::string word = ToString(kind);
  std::replace(word.begin(), word.end(), ' ', '_');
  std::replace(word.begin(), word.end(), '-', '_');
  return word;
}

}  // namespace

FaultRecorder::FaultRecorder(std::size_t cycles, int dof, std::string dir, std::string prefix, int max_files,
                             int joints)
    : capacity_(std::max<std::size_t>(cycles, 1)),
      dof_(dof),
      joints_(joints),
      dir_(std::move(dir)),
      prefix_(std::move(prefix)),
      max_files_(max_files),
      ring_(new runtime::TelemetryRecord[std::max<std::size_t>(cycles, 1)]),
      snapshot_(new runtime::TelemetryRecord[std::max<std::size_t>(cycles, 1)]) {
  file_of_.fill(-1);
  files_.reserve(static_cast<std::size_t>(std::max(max_files, 0)));
  thread_ = std::thread([this] {
    runtime::BecomeBackgroundThread("teleop-faultrec");
    while (!stop_.load(std::memory_order_acquire)) {
      WritePending();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    WritePending();
  });
}

FaultRecorder::~FaultRecorder() { Stop(); }

void FaultRecorder::Trigger(const Info& info) noexcept {
  const std::uint64_t index = faults_++;
  if (index < kMaxReports) infos_[index] = info;
  const bool busy = pending_.load(std::memory_order_acquire);
  if (busy || files_started_ >= max_files_ || index >= kMaxReports) {
    ++skipped_;
    return;
  }
  // Oldest first: the ring's last `count` records.
  const std::size_t count = static_cast<std::size_t>(std::min<std::uint64_t>(next_, capacity_));
  const std::uint64_t first = next_ - count;
  for (std::size_t k = 0; k < count; ++k) snapshot_[k] = ring_[(first + k) % capacity_];
  snapshot_count_ = count;
  snapshot_report_ = static_cast<std::size_t>(index);
  file_of_[index] = files_started_++;
  pending_.store(true, std::memory_order_release);
}

void FaultRecorder::WritePending() {
  if (!pending_.load(std::memory_order_acquire)) return;
  const Info& info = infos_[snapshot_report_];
  std::string name = fmt::format("teleop-{}-fault-{}-cycle{}-{}.csv", prefix_, file_of_[snapshot_report_] + 1,
                                 info.cycle, FileWord(info.kind));
  std::string path = dir_.empty() ? name : dir_ + "/" + name;
  std::FILE* file = std::fopen(path.c_str(), "w");
  if (file == nullptr) {
    const int err = errno;
    spdlog::error("fault record: cannot write '{}': {}", path, std::system_category().message(err));
    path = "(not written: " + std::system_category().message(err) + ")";
  } else {
    std::string text = runtime::TelemetryCsvHeader(dof_, joints_) + "\n";
    for (std::size_t k = 0; k < snapshot_count_; ++k) {
      text += runtime::TelemetryCsvRow(snapshot_[k], dof_, joints_) + "\n";
    }
    const bool ok = std::fwrite(text.data(), 1, text.size(), file) == text.size();
    const bool closed = std::fclose(file) == 0;
    if (ok && closed) {
      spdlog::warn("fault record: {} ({} cycles before the {} at cycle {})", path, snapshot_count_, ToString(info.kind),
                   info.cycle);
    } else {
      spdlog::error("fault record: writing '{}' failed", path);
      path = "(write failed: " + path + ")";
    }
  }
  files_.push_back(path);
  pending_.store(false, std::memory_order_release);
}

void FaultRecorder::Stop() {
  stop_.store(true, std::memory_order_release);
  if (thread_.joinable()) thread_.join();
}

std::vector<FaultReport> FaultRecorder::Reports() const {
  std::vector<FaultReport> out;
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(faults_, kMaxReports));
  for (std::size_t i = 0; i < n; ++i) {
    const Info& info = infos_[i];
    FaultReport r;
    r.kind = info.kind;
    r.cycle = info.cycle;
    r.time_s = info.time_s;
    r.reaction = info.device_safe_state ? "device safe state" : ToString(info.reaction);
    r.peer_sample_age_s = info.peer_sample_age_s;
    r.device_faults = info.device_faults;
    const int f = file_of_[i];
    if (f >= 0 && static_cast<std::size_t>(f) < files_.size()) r.file = files_[static_cast<std::size_t>(f)];
    out.push_back(r);
  }
  return out;
}

}  // namespace teleop::node
