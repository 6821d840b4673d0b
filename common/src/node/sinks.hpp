#pragma once

// The outputs of a cycle behind node::CycleSink (teleop/node/cycle_sink.hpp). Private to the node.

#include <memory>
#include <vector>

#include "teleop/config/process_config.hpp"
#include "teleop/node/cycle_sink.hpp"
#include "teleop/node/event_log.hpp"

namespace teleop::node {

/// The last safety.fault_record_cycles cycles before every fault, written to a file (FaultRecorder). `joints`: the
/// device's (device::Capabilities::joints), the joint columns of the records (0: none).
std::unique_ptr<CycleSink> MakeFaultRingSink(const config::ProcessConfig& config, int joints = 0);
/// telemetry.csv_path every telemetry.decimation cycles, with `joints` joint columns; null when no path is
/// configured.
std::unique_ptr<CycleSink> MakeTelemetryCsvSink(const config::ProcessConfig& config, int joints = 0);
/// The DDS bridge (docs/dds.md) at dds.state_rate_hz, its events and the summary; null when dds.enabled is off.
std::unique_ptr<CycleSink> MakeDdsSink(const config::ProcessConfig& config);

/// The sinks of one node, in order; the event log's observer (each sink's OnEvent).
class SinkSet final : public EventObserver {
 public:
  void Add(std::unique_ptr<CycleSink> sink) {
    if (sink) sinks_.push_back(std::move(sink));
  }
  void OnCycle(const CycleRecord& record) noexcept {
    for (const auto& s : sinks_) s->OnCycle(record);
  }
  void OnFault(const FaultRecorder::Info& info) noexcept {
    for (const auto& s : sinks_) s->OnFault(info);
  }
  void OnEvent(const Event& event) noexcept override {
    for (const auto& s : sinks_) s->OnEvent(event);
  }
  void Finish(RunSummary& summary) {
    for (const auto& s : sinks_) s->Finish(summary);
  }
  void Publish(const RunSummary& summary) {
    for (const auto& s : sinks_) s->Publish(summary);
  }

 private:
  std::vector<std::unique_ptr<CycleSink>> sinks_;
};

}  // namespace teleop::node
