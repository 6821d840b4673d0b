#pragma once

#include <array>
#include <cstdint>

#include "teleop/runtime/latency_histogram.hpp"

namespace teleop::runtime {

/// The age of the peer sample the law uses, measured every cycle (docs/performance.md, "Round trip and data age"):
///   - receive age: cycle start − the time the medium received the sample (the kernel's receive timestamp on UDP);
///   - sender age: cycle start − the time the peer sent it, on our clock (its send time minus the clock offset
///     estimated from the round trip; only once an offset is known);
///   - age in cycles: 0 when this cycle was started by the sample's arrival (a triggered cycle that polled it),
///     1 when it was already waiting when the cycle started (free-running: it arrived during the last period),
///     plus one for every further cycle that reused it (no newer sample came).
/// The discrete model's peer delay is the receive age over the period (stability.peer_delay_fraction); age in
/// cycles 0 is the fractional model, 1 its whole-sample model. Allocation-free, O(1) per cycle, one thread.
class DataAgeTracker {
 public:
  /// Buckets of the age in cycles: 0, 1, 2, 3 or more.
  static constexpr std::size_t kCycleBuckets = 4;

  /// A new sample became the one the law uses, this cycle. `receive_ns`: when the medium received it (loop clock).
  /// `sent_local_ns`: when the peer sent it, converted to the loop clock; 0 when unknown. `triggered`: this cycle
  /// was started by its arrival.
  void OnNewSample(std::int64_t receive_ns, std::int64_t sent_local_ns, bool triggered) noexcept;
  /// One cycle ran at `cycle_start_ns`; `used` says whether the law used the peer's sample in it. Records the
  /// ages when used; ages the sample by one cycle either way.
  void OnCycle(std::int64_t cycle_start_ns, bool used) noexcept;

  /// The receive age of the newest sample at `cycle_start_ns` (ns), or -1 when there is none.
  std::int64_t ReceiveAgeNs(std::int64_t cycle_start_ns) const noexcept {
    return have_sample_ ? cycle_start_ns - receive_ns_ : -1;
  }

  /// The sender age of the newest sample at `cycle_start_ns` (ns), or -1 when there is none or its send time is
  /// unknown (no clock offset yet).
  std::int64_t SenderAgeNs(std::int64_t cycle_start_ns) const noexcept {
    return have_sample_ && sent_local_ns_ != 0 ? cycle_start_ns - sent_local_ns_ : -1;
  }

  const LatencyHistogram& receive_age_ns() const noexcept { return receive_age_ns_; }
  const LatencyHistogram& sender_age_ns() const noexcept { return sender_age_ns_; }
  /// Cycles that used the peer's sample, by age in cycles (0, 1, 2, 3+).
  const std::array<std::uint64_t, kCycleBuckets>& age_cycles() const noexcept { return age_cycles_; }
  /// The median age in cycles over the cycles that used a sample (-1 when none did).
  int MedianAgeCycles() const noexcept;

 private:
  LatencyHistogram receive_age_ns_;
  LatencyHistogram sender_age_ns_;
  std::array<std::uint64_t, kCycleBuckets> age_cycles_{};
  std::int64_t receive_ns_ = 0;
  std::int64_t sent_local_ns_ = 0;
  std::uint64_t cycles_old_ = 0;
  bool have_sample_ = false;
};

}  // namespace teleop::runtime
