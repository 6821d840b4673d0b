// The DDS bridge as a cycle sink (docs/dds.md): its own thread publishes; the cycle only copies into its ring.

#include "sinks.hpp"
#include "teleop/dds/bridge.hpp"

namespace teleop::node {

namespace {

class DdsSink final : public CycleSink {
 public:
  explicit DdsSink(const config::ProcessConfig& config)
      : bridge_(config.dds, config.role, config.loop.rate_hz), decimation_(bridge_.decimation()) {}

  void OnCycle(const CycleRecord& r) noexcept override {
    if (r.telemetry->cycle % decimation_ != 0) return;
    dds::BridgeSample sample;
    sample.record = *r.telemetry;
    dds::EngagementInputs in;
    in.stopping = r.stopping;
    in.local_fault = r.local_fault;
    in.peer_fault = r.peer_fault;
    in.have_peer = r.have_peer;
    in.peer_shutdown = r.peer_shutdown;
    in.peer_fresh = r.peer_fresh;
    in.engaged = r.engagement == EngagementState::kEngaged;
    sample.engagement = dds::EngagementOf(in);
    sample.device_faults = r.device_faults;
    sample.overruns = r.overruns;
    sample.watchdog_trips = r.watchdog_trips;
    sample.link = *r.link;
    sample.tracking_error_m = r.tracking_error_m;
    (void)bridge_.PushState(sample);  // a full ring is counted by the bridge
  }
  void OnEvent(const Event& event) noexcept override { bridge_.OnEvent(event); }
  /// The summary goes out, then the bridge leaves the domain.
  void Publish(const RunSummary& summary) override {
    bridge_.PublishSummary(summary, FormatSummaryJson(summary));
    bridge_.Stop();
  }

 private:
  dds::Bridge bridge_;
  std::uint64_t decimation_;
};

}  // namespace

std::unique_ptr<CycleSink> MakeDdsSink(const config::ProcessConfig& config) {
  if (!config.dds.enabled) return nullptr;
  return std::make_unique<DdsSink>(config);
}

}  // namespace teleop::node
