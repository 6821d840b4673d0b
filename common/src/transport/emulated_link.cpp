#include "teleop/transport/emulated_link.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <span>
#include <string>

#include "sample_intake.hpp"
#include "teleop/error.hpp"

namespace teleop::transport {
namespace {

std::size_t Index(proto::SenderRole from) noexcept { return from == proto::SenderRole::kMaster ? 0 : 1; }

}  // namespace

// Each direction is one ImpairmentModel (the model ImpairedLink uses in the processes), on simulated time.
struct EmulatedMedium::Impl {
  explicit Impl(const EmulatedMediumConfig& c)
      : config(c),
        channels{{ImpairmentModel(c.master_to_slave, c.seed, "emulated link master->slave"),
                  ImpairmentModel(c.slave_to_master, c.seed ^ 0x9E3779B97F4A7C15ull, "emulated link slave->master")}} {}

  bool Enqueue(proto::SenderRole from, const proto::SampleMessage& message) noexcept {
    const std::size_t size = proto::EncodeSample(message, scratch);
    if (size == 0) return false;
    ImpairmentModel& ch = channels[Index(from)];
    return ch.Offer(std::span<const std::uint8_t>(scratch.data(), size), now_ns) != ImpairmentModel::Verdict::kOverflow;
  }

  // Hands every datagram due for `to` to the intake, in (due time, order) order.
  void Deliver(proto::SenderRole to, detail::SampleIntake& intake, LinkCounters& counters) noexcept {
    ImpairmentModel& ch = channels[Index(proto::PeerOf(to))];
    ch.BeginDelivery(now_ns);
    ImpairmentModel::Delivery d;
    while (ch.NextDelivery(d)) intake.Offer(d.bytes, counters);
  }

  const DirectionStats& Stats(proto::SenderRole from) noexcept {
    const ImpairmentCounters& c = channels[Index(from)].counters();
    DirectionStats& s = stats[Index(from)];
    s.offered = c.offered - c.dropped_overflow;
    s.dropped = c.dropped_loss + c.dropped_burst + c.dropped_outage + c.dropped_bandwidth;
    s.duplicated = c.duplicated;
    s.reordered = c.reordered;
    s.corrupted = c.corrupted;
    s.overflowed = c.dropped_overflow + c.copies_refused;
    s.delivered = c.delivered;
    return s;
  }

  EmulatedMediumConfig config;
  std::array<ImpairmentModel, 2> channels;
  std::array<DirectionStats, 2> stats{};
  std::array<std::uint8_t, ImpairmentModel::kMaxDatagramBytes> scratch{};
  std::int64_t now_ns = 0;
};

EmulatedMedium::EmulatedMedium(const EmulatedMediumConfig& config) : impl_(std::make_unique<Impl>(config)) {}
EmulatedMedium::~EmulatedMedium() = default;

void EmulatedMedium::Advance(double dt_s) noexcept {
  if (!std::isfinite(dt_s) || dt_s <= 0.0) return;
  impl_->now_ns += std::llround(dt_s * 1e9);
}
std::int64_t EmulatedMedium::now_ns() const noexcept { return impl_->now_ns; }
double EmulatedMedium::now_s() const noexcept { return static_cast<double>(impl_->now_ns) * 1e-9; }
const EmulatedMedium::DirectionStats& EmulatedMedium::stats(proto::SenderRole from) const noexcept {
  return impl_->Stats(from);
}
const ImpairmentCounters& EmulatedMedium::impairments(proto::SenderRole from) const noexcept {
  return impl_->channels[Index(from)].counters();
}
const EmulatedMediumConfig& EmulatedMedium::config() const noexcept { return impl_->config; }

struct EmulatedLink::Intake {
  explicit Intake(proto::SenderRole expected) : receive(expected) {}
  detail::SampleIntake receive;
};

EmulatedLink::EmulatedLink(std::shared_ptr<EmulatedMedium> medium, proto::SenderRole local)
    : medium_(std::move(medium)), local_(local), intake_(std::make_unique<Intake>(proto::PeerOf(local))) {
  if (medium_ == nullptr) throw Error("emulated link: no medium given");
}
EmulatedLink::~EmulatedLink() = default;

bool EmulatedLink::Send(const proto::SampleMessage& message) noexcept {
  if (!medium_->impl_->Enqueue(local_, message)) {
    ++counters_.send_errors;
    return false;
  }
  ++counters_.sent;
  return true;
}

bool EmulatedLink::Poll(proto::SampleMessage& newest) noexcept {
  intake_->receive.Begin();
  medium_->impl_->Deliver(local_, intake_->receive, counters_);
  return intake_->receive.Finish(newest, counters_);
}

std::string EmulatedLink::Describe() const {
  const EmulatedMediumConfig& c = medium_->config();
  const EmulatedLinkConfig& out = local_ == proto::SenderRole::kMaster ? c.master_to_slave : c.slave_to_master;
  std::array<char, 256> text{};
  std::snprintf(text.data(), text.size(),
                "emulated %s->%s (delay %.3f ms, loss %.3f, dup %.3f, reorder %.3f, corrupt %.3f",
                proto::ToString(local_), proto::ToString(proto::PeerOf(local_)), out.delay_s * 1e3,
                out.loss_probability, out.duplicate_probability, out.reorder_probability, out.corrupt_probability);
  std::string extra;
  if (out.jitter_s > 0 || out.burst.enter_probability > 0 || out.bandwidth_bit_per_s > 0 || !out.outages.empty()) {
    extra = "; " + medium_->impl_->channels[local_ == proto::SenderRole::kMaster ? 0 : 1].Describe();
    extra = extra.substr(0, extra.rfind(", seed"));
  }
  return std::string(text.data()) + extra + ", seed " + std::to_string(c.seed) + ")";
}

EmulatedLinkPair MakeEmulatedLinkPair(const EmulatedMediumConfig& config) {
  EmulatedLinkPair pair;
  pair.medium = std::make_shared<EmulatedMedium>(config);
  pair.master = std::make_unique<EmulatedLink>(pair.medium, proto::SenderRole::kMaster);
  pair.slave = std::make_unique<EmulatedLink>(pair.medium, proto::SenderRole::kSlave);
  return pair;
}

EmulatedLinkPair MakeEmulatedLinkPair(const EmulatedLinkConfig& both_directions, std::uint64_t seed) {
  return MakeEmulatedLinkPair(EmulatedMediumConfig{both_directions, both_directions, seed});
}

}  // namespace teleop::transport
