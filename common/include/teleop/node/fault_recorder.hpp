#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "teleop/node/engagement.hpp"
#include "teleop/runtime/telemetry.hpp"

namespace teleop::node {

/// One fault as the summary reports it: what, when, what the process did, and the file with the cycles before it.
struct FaultReport {
  Outage kind = Outage::kNone;
  std::uint64_t cycle = 0;
  double time_s = 0.0;
  std::string reaction;             ///< What the process did ("hold", "device safe state", ...).
  double peer_sample_age_s = 0;     ///< Age of the newest peer sample when the fault started (s); NaN: none.
  std::string file;                 ///< The fault record (CSV); empty when not written (limit reached, writer busy).
  std::uint32_t device_faults = 0;  ///< Device fault bits (kDeviceFault).
};

/// The last N cycles before every fault, written to a CSV file (the telemetry columns) outside the cycle.
///
/// The cycle calls Record() every cycle (a copy into a preallocated ring) and Trigger() when a fault starts: the
/// ring is copied into a preallocated snapshot and handed to the recorder's own thread, which writes the file and
/// logs its name. A fault that finds the snapshot still being written, or comes after max_files, is reported in the
/// summary without a file and counted (skipped()). Record and Trigger are allocation-free, lock-free, noexcept.
class FaultRecorder {
 public:
  /// What the cycle knows about a fault when it starts (trivially copyable).
  struct Info {
    Outage kind = Outage::kNone;
    std::uint64_t cycle = 0;
    double time_s = 0.0;
    Reaction reaction = Reaction::kZeroForce;
    bool device_safe_state = false;  ///< The device was put into its safe state (Device::SetSafe) instead.
    double peer_sample_age_s = 0.0;
    std::uint32_t device_faults = 0;
  };
  static constexpr std::size_t kMaxReports = 256;  ///< Faults listed in the summary; later ones only counted.

  /// `cycles` ≥ 1 kept; files `<dir>/teleop-<prefix>-fault-<n>-cycle<c>-<kind>.csv`; `dof` columns per vector,
  /// `joints` joint columns (the telemetry CSV's: runtime::TelemetryCsvHeader).
  FaultRecorder(std::size_t cycles, int dof, std::string dir, std::string prefix, int max_files, int joints = 0);
  ~FaultRecorder();
  FaultRecorder(const FaultRecorder&) = delete;
  FaultRecorder& operator=(const FaultRecorder&) = delete;

  void Record(const runtime::TelemetryRecord& record) noexcept {
    ring_[next_ % capacity_] = record;
    ++next_;
  }
  void Trigger(const Info& info) noexcept;
  /// Writes what is pending and joins the thread. Idempotent.
  void Stop();
  /// After Stop(): every fault triggered, in order (at most kMaxReports).
  std::vector<FaultReport> Reports() const;
  std::uint64_t faults() const noexcept { return faults_; }
  /// Faults whose record was not written (writer busy or max_files reached).
  std::uint64_t skipped() const noexcept { return skipped_; }

 private:
  void WritePending();

  std::size_t capacity_;
  int dof_;
  int joints_;
  std::string dir_;
  std::string prefix_;
  int max_files_;
  std::unique_ptr<runtime::TelemetryRecord[]> ring_;
  std::uint64_t next_ = 0;
  std::unique_ptr<runtime::TelemetryRecord[]> snapshot_;
  std::size_t snapshot_count_ = 0;
  std::size_t snapshot_report_ = 0;  ///< Index into infos_ of the snapshot's fault.
  std::atomic<bool> pending_{false};
  std::array<Info, kMaxReports> infos_{};
  std::array<int, kMaxReports> file_of_{};  ///< Index into files_, or -1.
  std::uint64_t faults_ = 0;
  std::uint64_t skipped_ = 0;
  int files_started_ = 0;
  std::vector<std::string> files_;  ///< Written by the thread; read after Stop().
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace teleop::node
