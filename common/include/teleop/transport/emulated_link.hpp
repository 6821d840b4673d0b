#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "teleop/transport/impairment_model.hpp"
#include "teleop/transport/link.hpp"

namespace teleop::transport {

/// Impairments of one direction of an emulated link: the shared impairment model's settings (delay and jitter in
/// simulated time; a datagram sent at t is delivered by the first Poll at simulated time ≥ t + its delay).
/// A datagram beyond `capacity` in flight is refused (send error).
using EmulatedLinkConfig = ImpairmentConfig;

/// Both directions of an emulated link, their simulated clock and seed.
struct EmulatedMediumConfig {
  EmulatedLinkConfig master_to_slave{};
  EmulatedLinkConfig slave_to_master{};
  std::uint64_t seed = 1;  ///< Same seed, same calls => same deliveries, bit for bit.
};

/// The channel between two EmulatedLink endpoints in one process: a user-space "network" with a simulated clock
/// that only moves when Advance() is called, so closed-loop tests stepping both sides in one thread are exact and
/// deterministic. Datagrams go through the real encoder and decoder, so rejections are counted exactly as on UDP.
/// Not thread-safe: both endpoints and Advance() are called from one thread. Allocation-free after construction.
class EmulatedMedium {
 public:
  /// What the channel did to the datagrams of one direction (the ground truth the link counters are checked
  /// against in tests).
  struct DirectionStats {
    std::uint64_t offered = 0;     ///< Send calls with an encodable sample.
    std::uint64_t dropped = 0;     ///< Lost on purpose (loss_probability).
    std::uint64_t duplicated = 0;  ///< Extra copies put in flight.
    std::uint64_t reordered = 0;   ///< Datagrams that overtook their predecessor.
    std::uint64_t corrupted = 0;   ///< Copies with flipped bits.
    std::uint64_t overflowed = 0;  ///< Refused (or copies not made) because capacity was full.
    std::uint64_t delivered = 0;   ///< Handed to the receiving endpoint.
  };
  /// The full counters of the impairment model of the direction whose sender is `from` (bursts, outages, ...).
  const ImpairmentCounters& impairments(proto::SenderRole from) const noexcept;

  /// Throws teleop::Error on a setting the impairment model refuses (ImpairmentModel's constructor).
  explicit EmulatedMedium(const EmulatedMediumConfig& config);
  ~EmulatedMedium();
  EmulatedMedium(const EmulatedMedium&) = delete;
  EmulatedMedium& operator=(const EmulatedMedium&) = delete;

  /// Moves simulated time forward by dt_s (negative or non-finite: ignored). Nothing is delivered here:
  /// datagrams that are due are read by the receiving endpoint's next Poll.
  void Advance(double dt_s) noexcept;
  std::int64_t now_ns() const noexcept;
  double now_s() const noexcept;
  /// Stats of the direction whose sender is `from`.
  const DirectionStats& stats(proto::SenderRole from) const noexcept;
  const EmulatedMediumConfig& config() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  friend class EmulatedLink;
};

/// One end of an emulated link, for the process of role `local`: sends into the medium, and Poll() reads what
/// the medium has delivered to `local` by now, through the same receive path as UdpLink (decode, role check,
/// sequence tracking, newest wins).
class EmulatedLink final : public Link {
 public:
  EmulatedLink(std::shared_ptr<EmulatedMedium> medium, proto::SenderRole local);
  ~EmulatedLink() override;

  [[nodiscard]] bool Send(const proto::SampleMessage& message) noexcept override;
  [[nodiscard]] bool Poll(proto::SampleMessage& newest) noexcept override;
  const LinkCounters& counters() const noexcept override { return counters_; }
  std::string Describe() const override;
  EmulatedMedium& medium() noexcept { return *medium_; }

 private:
  struct Intake;
  std::shared_ptr<EmulatedMedium> medium_;
  proto::SenderRole local_;
  std::unique_ptr<Intake> intake_;
  LinkCounters counters_{};
};

/// A medium and its two endpoints.
struct EmulatedLinkPair {
  std::shared_ptr<EmulatedMedium> medium;
  std::unique_ptr<EmulatedLink> master;  ///< The master process's end: sends as master, accepts the slave's.
  std::unique_ptr<EmulatedLink> slave;   ///< The slave process's end.
};

EmulatedLinkPair MakeEmulatedLinkPair(const EmulatedMediumConfig& config);
/// Same impairments both ways.
EmulatedLinkPair MakeEmulatedLinkPair(const EmulatedLinkConfig& both_directions, std::uint64_t seed = 1);

}  // namespace teleop::transport
