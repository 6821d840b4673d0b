#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "teleop/proto/codec.hpp"
#include "teleop/proto/sample_message.hpp"

namespace teleop::transport {

/// Burst loss, the Gilbert–Elliott two-state channel: before each datagram the channel moves good → bad with
/// `enter_probability` and bad → good with `exit_probability`; in the bad state a datagram is lost with
/// `loss_probability`. Mean burst length 1 / exit_probability datagrams; fraction of time in bursts
/// enter / (enter + exit). Off while enter_probability is 0.
struct BurstLossConfig {
  double enter_probability = 0.0;  ///< p, good → bad, per datagram.
  double exit_probability = 1.0;   ///< r, bad → good, per datagram, > 0.
  double loss_probability = 1.0;   ///< Loss in the bad state (1 - h).
};

/// A scheduled outage: everything offered from start_s for duration_s (since the model's origin) is dropped.
struct Outage {
  double start_s = 0.0;
  double duration_s = 0.0;
};

/// From `at_s` after the model's origin (Start()) on, the fixed delay is `delay_s` (a link that gets slower or faster
/// mid-run; docs/link-emulation.md, "A delay that steps").
struct DelayStep {
  double at_s = 0.0;
  double delay_s = 0.0;
};

/// What the channel does to one direction's datagrams. Probabilities are per datagram, drawn independently, each
/// impairment from its own random stream (changing one setting never changes which datagrams another hits).
struct ImpairmentConfig {
  double delay_s = 0.0;                ///< Fixed one-way delay, ≥ 0: delivered from offer time + delay_s on.
  double loss_probability = 0.0;       ///< Independent random loss.
  double duplicate_probability = 0.0;  ///< Delivered twice: the copy right behind the original.
  double reorder_probability = 0.0;    ///< Overtakes the previous datagram still in flight (delivered just ahead
                                       ///< of it). Needs a delay longer than the interval between datagrams.
  double corrupt_probability = 0.0;    ///< 1..3 random bits flipped in flight (the receiver's checks reject it).
  int capacity = 64;                   ///< Datagrams in flight (the delay line's slots); beyond it: dropped.
  double jitter_s = 0.0;  ///< Extra delay uniform in [0, jitter_s). Datagrams still leave in the order they came
                          ///< (a queue, not parallel paths): jitter never reorders; reorder_probability does.
  BurstLossConfig burst{};
  double bandwidth_bit_per_s = 0.0;  ///< 0 = unlimited. Else each datagram occupies the line for its bits / rate,
                                     ///< after those queued before it.
  double queue_limit_s = 0.05;       ///< With a bandwidth cap: a datagram that would wait longer is dropped.
  std::vector<Outage> outages;       ///< Scheduled outages, since the model's origin (Start()).
  /// The fixed delay steps to each one's delay_s at its at_s (ascending); before the first, delay_s. The queue still
  /// holds: a datagram is never due before the one ahead of it, so a step down drains what is in flight first.
  std::vector<DelayStep> delay_steps;
};

/// What the channel did. Every offered datagram ends in exactly one place:
///   offered + duplicated == delivered + dropped() + in_flight
struct ImpairmentCounters {
  std::uint64_t offered = 0;            ///< Datagrams given to Offer().
  std::uint64_t delivered = 0;          ///< Handed out by NextDelivery() (copies included).
  std::uint64_t dropped_loss = 0;       ///< Random loss (loss_probability).
  std::uint64_t dropped_burst = 0;      ///< Lost in a Gilbert–Elliott burst.
  std::uint64_t dropped_outage = 0;     ///< Offered during a scheduled outage.
  std::uint64_t dropped_bandwidth = 0;  ///< The bandwidth queue was full (would wait > queue_limit_s).
  std::uint64_t dropped_overflow = 0;   ///< No free slot in the delay line (capacity), or not a datagram it holds.
  std::uint64_t duplicated = 0;         ///< Extra copies put in flight.
  std::uint64_t copies_refused = 0;     ///< Duplicates not made for want of a free slot (not in duplicated).
  std::uint64_t reordered = 0;          ///< Datagrams that overtook their predecessor.
  std::uint64_t corrupted = 0;          ///< Datagrams (originals or copies) with flipped bits.
  std::uint64_t delayed = 0;            ///< Delivered later than offered (delay, jitter or the bandwidth queue).
  std::uint64_t dropped() const noexcept {
    return dropped_loss + dropped_burst + dropped_outage + dropped_bandwidth + dropped_overflow;
  }
};

/// One direction of an impaired channel: a delay line of preallocated slots that datagrams enter with Offer() and
/// leave, once due, through BeginDelivery()/NextDelivery(), in (due time, order) order. Seeded: the same seed and
/// the same calls (bytes and times) give the same impairments, bit for bit, on every platform (the random streams
/// are std::mt19937_64 read through their raw output, not the library's distributions).
///
/// Shared by the in-process EmulatedMedium (simulated time) and ImpairedLink (a process's link, monotonic clock).
/// Not thread-safe. After construction: no allocation, no lock, no exception.
class ImpairmentModel {
 public:
  /// The largest datagram a slot holds (a sample of kMaxWireDof DOF).
  static constexpr std::size_t kMaxDatagramBytes = proto::kMaxEncodedSampleBytes;  // with the passivity energy block

  enum class Verdict : std::uint8_t { kQueued, kDropped, kOverflow };

  /// One datagram handed out: valid until the next NextDelivery() or Offer().
  struct Delivery {
    std::span<const std::uint8_t> bytes;
    std::int64_t due_ns = 0;  ///< When the channel delivered it (≤ the BeginDelivery time).
  };

  /// Throws teleop::Error naming `name` and the setting: a probability outside [0, 1], a negative or non-finite
  /// time, exit_probability 0 with bursts on, capacity outside 1..65536, a negative bandwidth, an outage with a
  /// negative start or a non-positive duration, delay steps not ascending or with a negative time or delay.
  ImpairmentModel(const ImpairmentConfig& config, std::uint64_t seed, const std::string& name);
  ~ImpairmentModel();
  ImpairmentModel(const ImpairmentModel&) = delete;
  ImpairmentModel& operator=(const ImpairmentModel&) = delete;

  /// Sets the origin of the outage schedule (default 0).
  void Start(std::int64_t origin_ns) noexcept;
  /// A datagram enters the channel at `now_ns`. Empty datagrams and those longer than kMaxDatagramBytes are refused
  /// (kOverflow), like one that finds no free slot.
  Verdict Offer(std::span<const std::uint8_t> bytes, std::int64_t now_ns) noexcept;
  /// Collects the datagrams due at `now_ns`; NextDelivery() then hands them out one by one and frees their slots.
  void BeginDelivery(std::int64_t now_ns) noexcept;
  bool NextDelivery(Delivery& out) noexcept;
  /// Drops everything in flight without delivering it (counted nowhere: the caller says why).
  void Clear() noexcept;

  std::size_t in_flight() const noexcept;
  const ImpairmentCounters& counters() const noexcept;
  const ImpairmentConfig& config() const noexcept;
  std::uint64_t seed() const noexcept;
  /// "delay 20.000 ms, jitter 5.000 ms, loss 0.050, ..." : the settings that are on.
  std::string Describe() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// "offered N, delivered N, dropped loss/burst/outage/bandwidth/overflow a/b/c/d/e, duplicated N, reordered N,
/// corrupted N, delayed N".
std::string FormatImpairmentCounters(const ImpairmentCounters& counters);
/// The same as one JSON object (keys as the field names).
std::string ImpairmentCountersJson(const ImpairmentCounters& counters);

}  // namespace teleop::transport
