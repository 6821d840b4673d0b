#include "sinks.hpp"

#include <filesystem>
#include <string>

#include "teleop/runtime/telemetry.hpp"

namespace teleop::node {

namespace {

/// Where fault records go: safety.fault_record_dir, else the telemetry CSV's directory, else the working directory.
std::string FaultRecordDir(const config::ProcessConfig& config) {
  if (!config.safety.fault_record_dir.empty()) return config.safety.fault_record_dir;
  if (!config.telemetry.csv_path.empty()) {
    const std::filesystem::path parent = std::filesystem::path(config.telemetry.csv_path).parent_path();
    if (!parent.empty()) return parent.string();
  }
  return ".";
}

class FaultRingSink final : public CycleSink {
 public:
  FaultRingSink(const config::ProcessConfig& config, int joints)
      : faults_(static_cast<std::size_t>(config.safety.fault_record_cycles), config.dof, FaultRecordDir(config),
                ToString(config.role), config.safety.max_fault_records, joints) {}
  void OnCycle(const CycleRecord& record) noexcept override { faults_.Record(*record.telemetry); }
  void OnFault(const FaultRecorder::Info& info) noexcept override { faults_.Trigger(info); }
  void Finish(RunSummary& summary) override {
    faults_.Stop();
    summary.faults = faults_.Reports();
    summary.fault_records_skipped = faults_.skipped();
  }

 private:
  FaultRecorder faults_;
};

class TelemetryCsvSink final : public CycleSink {
 public:
  TelemetryCsvSink(const config::ProcessConfig& config, int joints)
      : writer_(config.telemetry.csv_path, static_cast<std::size_t>(config.telemetry.ring_capacity), config.dof,
                joints),
        decimation_(static_cast<std::uint64_t>(config.telemetry.decimation)) {}
  void OnCycle(const CycleRecord& record) noexcept override {
    if (record.telemetry->cycle % decimation_ == 0 && writer_.Push(*record.telemetry)) ++records_;
  }
  void Finish(RunSummary& summary) override {
    writer_.Stop();
    summary.telemetry_records = records_;
    summary.telemetry_dropped = writer_.dropped();
  }

 private:
  runtime::TelemetryWriter writer_;
  std::uint64_t decimation_;
  std::uint64_t records_ = 0;
};

}  // namespace

std::unique_ptr<CycleSink> MakeFaultRingSink(const config::ProcessConfig& config, int joints) {
  return std::make_unique<FaultRingSink>(config, joints);
}

std::unique_ptr<CycleSink> MakeTelemetryCsvSink(const config::ProcessConfig& config, int joints) {
  if (config.telemetry.csv_path.empty()) return nullptr;
  return std::make_unique<TelemetryCsvSink>(config, joints);
}

}  // namespace teleop::node
