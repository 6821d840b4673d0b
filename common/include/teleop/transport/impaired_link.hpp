#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "teleop/transport/impairment_model.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::transport {

/// A link wrapped in an emulated bad network (config `link.emulate`, docs/link-emulation.md), on the receive side:
/// every sample the wrapped link accepts is encoded again and enters the shared ImpairmentModel (delay, jitter,
/// loss, bursts, outages, bandwidth, reordering, duplication, corruption) on the monotonic clock; what the model
/// delivers goes through the same receive path as every link (decode with CRC, role check, sequence tracking,
/// newest wins) before the loop sees it. Send() goes straight to the wrapped link.
///
/// Why the receive side: each process impairs what it receives, so the impairments of one direction are
/// configured, counted and reported by the process that suffers them; corrupted bits meet the real decoder after
/// the sender's CRC; the wrapped link's own counters (and its invariant received == accepted + superseded +
/// reordered + duplicates + rejected) are untouched, and so is what goes on the wire (the peer, a capture, the
/// CAN bus load see the real traffic).
///
/// counters() is what the loop saw: the wrapped link's sends and medium errors, its discards (rejected,
/// superseded, reordered, duplicates) plus those of the emulated stage; accepted and lost are the emulated
/// stage's (a sample the wrapped link lost is a gap here too). The invariant holds for this view as well.
/// Send/Poll: no allocation, no lock, no exception (the delay line is preallocated).
class ImpairedLink final : public Link {
 public:
  using Clock = std::int64_t (*)() noexcept;

  /// Throws teleop::Error when `inner` is null or the impairments are invalid. `clock` (CLOCK_MONOTONIC ns by
  /// default) is read at construction (origin of the outage schedule) and once per Poll.
  ImpairedLink(std::unique_ptr<Link> inner, const ImpairmentConfig& impairments, std::uint64_t seed,
               proto::SenderRole expected_peer, Clock clock = nullptr);
  ~ImpairedLink() override;

  [[nodiscard]] bool Send(const proto::SampleMessage& message) noexcept override;
  [[nodiscard]] bool Poll(proto::SampleMessage& newest) noexcept override;
  const LinkCounters& counters() const noexcept override { return counters_; }
  std::string Describe() const override;
  bool faulted() const noexcept override { return inner_->faulted(); }
  /// When the emulated channel delivered the newest sample.
  std::int64_t newest_receive_time_ns() const noexcept override { return newest_receive_time_ns_; }
  std::uint64_t session_epoch() const noexcept override { return inner_->session_epoch(); }
  /// "wrapped link: received N, accepted N, lost N, superseded N, rejected N; <the wrapped link's own summary>" (the
  /// emulation's own counters are impairments(), in the run summary's link_emulation).
  std::string Summary() const override;

  const ImpairmentCounters& impairments() const noexcept;
  const Link& inner() const noexcept { return *inner_; }

 private:
  struct Stage;
  void Merge() noexcept;

  std::unique_ptr<Link> inner_;
  std::unique_ptr<Stage> stage_;
  Clock clock_;
  LinkCounters counters_{};
  std::int64_t newest_receive_time_ns_ = 0;
  std::uint64_t epoch_ = 0;
};

/// The emulation counters of `link` when it is an ImpairedLink, else null (the run summary's `link_emulation`).
const ImpairmentCounters* EmulationCountersOf(const Link& link) noexcept;

}  // namespace teleop::transport
