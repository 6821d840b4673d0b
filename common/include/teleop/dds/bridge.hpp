#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "teleop/dds/bridge_config.hpp"
#include "teleop/dds/bridge_sample.hpp"
#include "teleop/node/event_log.hpp"
#include "teleop/node/run_summary.hpp"
#include "teleop/types.hpp"

namespace teleop::dds {

/// Publishes one process's state, events and run summary on Cyclone DDS (docs/dds.md), from its own thread:
///   - PushState() is called by the real-time loop at the state rate: a copy into a lock-free ring, nothing else
///     (never blocks, never allocates, never calls DDS; a full ring drops the record and counts it);
///   - OnEvent() is called on the event log's thread (node::EventObserver): another ring;
///   - the bridge thread drains both rings every few milliseconds and writes the DDS samples;
///   - PublishSummary() (after the loop) writes the run summary; Stop() drains, waits a bounded time for
///     subscribers to acknowledge, and leaves the domain.
/// Everything DDS lives behind this class: the loop's code does not change with or without TELEOP_DDS.
class Bridge : public node::EventObserver {
 public:
  /// Joins DDS domain `config.domain_id` and creates the topics rt/teleop/<pair>/<role>/{state,events,summary}.
  /// Throws teleop::Error when DDS cannot be started, or when this build has no DDS (TELEOP_DDS=OFF).
  Bridge(const BridgeConfig& config, Role role, double loop_rate_hz);
  ~Bridge() override;
  Bridge(const Bridge&) = delete;
  Bridge& operator=(const Bridge&) = delete;

  /// True when this build can publish on DDS (TELEOP_DDS=ON).
  static bool Available() noexcept;

  /// Loop cycles between two PushState() calls: round(loop_rate_hz / state_rate_hz), at least 1.
  std::uint64_t decimation() const noexcept { return decimation_; }

  /// From the real-time thread (single producer). False when the ring was full and the record was dropped.
  [[nodiscard]] bool PushState(const BridgeSample& sample) noexcept;
  /// From the event log's thread (single producer).
  void OnEvent(const node::Event& event) noexcept override;
  /// After the loop has stopped (not real-time). `summary_json` is FormatSummaryJson(summary).
  void PublishSummary(const node::RunSummary& summary, const std::string& summary_json);
  /// Drains, publishes what is left, waits up to ~1 s for reliable subscribers, deletes the participant.
  /// Idempotent; the destructor calls it.
  void Stop();

  std::uint64_t states_published() const noexcept;
  std::uint64_t states_dropped() const noexcept;
  std::uint64_t events_published() const noexcept;
  std::uint64_t events_dropped() const noexcept;

 private:
  struct Impl;
  std::uint64_t decimation_ = 1;
  std::unique_ptr<Impl> impl_;
};

/// "peer_lost", "device_fault", ... for node::Event::Kind (the Event message's kind_name).
const char* EventKindName(node::Event::Kind kind) noexcept;

}  // namespace teleop::dds
