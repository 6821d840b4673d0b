#include "teleop/transport/emulated_link.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "sample_intake.hpp"
#include "teleop/error.hpp"

namespace teleop::transport {
namespace {

constexpr std::size_t kMaxSampleBytes = proto::kMaxEncodedSampleBytes;
// Delivery order within one instant: slots sort by (deliver_ns, order). Sends are kOrderStep apart so that an
// overtaking datagram (order - 1) and a duplicate (order + 1) fit between neighbours.
constexpr std::uint64_t kOrderStep = 1024;

std::size_t Index(proto::SenderRole from) noexcept { return from == proto::SenderRole::kMaster ? 0 : 1; }

void CheckProbability(double p, const char* name, const char* direction) {
  if (!(p >= 0.0 && p <= 1.0)) {
    throw Error(std::string("emulated link ") + direction + ": " + name + " must be in [0, 1], got " +
                std::to_string(p));
  }
}

struct Slot {
  bool used = false;
  std::int64_t deliver_ns = 0;
  std::uint64_t order = 0;
  std::size_t size = 0;
  std::array<std::uint8_t, kMaxSampleBytes> bytes{};
};

// One direction: a fixed pool of in-flight datagrams and its own random stream.
struct Channel {
  Channel(const EmulatedLinkConfig& c, std::uint64_t seed, const char* direction) : config(c), rng(seed), delay_ns(0) {
    if (!std::isfinite(c.delay_s) || c.delay_s < 0.0) {
      throw Error(std::string("emulated link ") + direction + ": delay_s must be finite and >= 0, got " +
                  std::to_string(c.delay_s));
    }
    CheckProbability(c.loss_probability, "loss_probability", direction);
    CheckProbability(c.duplicate_probability, "duplicate_probability", direction);
    CheckProbability(c.reorder_probability, "reorder_probability", direction);
    CheckProbability(c.corrupt_probability, "corrupt_probability", direction);
    if (c.capacity < 1 || c.capacity > 1 << 16) {
      throw Error(std::string("emulated link ") + direction + ": capacity must be 1..65536, got " +
                  std::to_string(c.capacity));
    }
    delay_ns = std::llround(c.delay_s * 1e9);
    slots.resize(static_cast<std::size_t>(c.capacity));
    due.reserve(slots.size());
  }

  // Uniform in [0, 1) from the top 53 bits: the same on every standard library (unlike the std distributions).
  double Uniform() noexcept { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }
  bool Chance(double p) noexcept { return p > 0.0 && Uniform() < p; }

  Slot* FreeSlot() noexcept {
    for (Slot& s : slots) {
      if (!s.used) return &s;
    }
    return nullptr;
  }

  void Corrupt(Slot& slot) noexcept {
    const int flips = 1 + static_cast<int>(rng() % 3);
    for (int i = 0; i < flips; ++i) {
      const std::uint64_t bit = rng() % (slot.size * 8);
      slot.bytes[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
  }

  EmulatedLinkConfig config;
  std::mt19937_64 rng;
  std::int64_t delay_ns;
  std::vector<Slot> slots;
  std::vector<Slot*> due;        // scratch for delivery, capacity reserved
  Slot* last = nullptr;          // the most recently enqueued slot, while still in flight
  std::uint64_t last_order = 0;  // its order when enqueued (to detect that the slot was reused)
  std::uint64_t next_order = kOrderStep;
  EmulatedMedium::DirectionStats stats{};
};

}  // namespace

struct EmulatedMedium::Impl {
  explicit Impl(const EmulatedMediumConfig& c)
      : config(c),
        channels{{Channel(c.master_to_slave, c.seed, "master->slave"),
                  Channel(c.slave_to_master, c.seed ^ 0x9E3779B97F4A7C15ull, "slave->master")}} {}

  bool Enqueue(proto::SenderRole from, const proto::SampleMessage& message) noexcept {
    Channel& ch = channels[Index(from)];
    Slot* slot = ch.FreeSlot();
    if (slot == nullptr) {
      ++ch.stats.overflowed;
      return false;
    }
    const std::size_t size = proto::EncodeSample(message, slot->bytes);
    if (size == 0) return false;
    ++ch.stats.offered;
    // Every draw is made for every datagram, so one impairment's setting does not shift another's stream.
    const bool lose = ch.Chance(ch.config.loss_probability);
    const bool duplicate = ch.Chance(ch.config.duplicate_probability);
    const bool overtake = ch.Chance(ch.config.reorder_probability);
    const bool corrupt = ch.Chance(ch.config.corrupt_probability);
    const bool corrupt_copy = ch.Chance(ch.config.corrupt_probability);
    if (lose) {
      ++ch.stats.dropped;
      return true;  // the sender cannot tell
    }
    slot->used = true;
    slot->size = size;
    slot->deliver_ns = now_ns + ch.delay_ns;
    slot->order = ch.next_order;
    ch.next_order += kOrderStep;
    const bool predecessor_in_flight = ch.last != nullptr && ch.last->used && ch.last->order == ch.last_order;
    if (overtake && predecessor_in_flight) {
      slot->deliver_ns = ch.last->deliver_ns;
      slot->order = ch.last->order - 1;
      ++ch.stats.reordered;
    }
    ch.last = slot;
    ch.last_order = slot->order;
    if (duplicate) {
      Slot* copy = ch.FreeSlot();
      if (copy == nullptr) {
        ++ch.stats.overflowed;
      } else {
        *copy = *slot;
        copy->order = slot->order + 1;
        ++ch.stats.duplicated;
        if (corrupt_copy) {
          ch.Corrupt(*copy);
          ++ch.stats.corrupted;
        }
      }
    }
    if (corrupt) {
      ch.Corrupt(*slot);
      ++ch.stats.corrupted;
    }
    return true;
  }

  // Hands every datagram due for `to` to the intake, in (deliver_ns, order) order.
  void Deliver(proto::SenderRole to, detail::SampleIntake& intake, LinkCounters& counters) noexcept {
    Channel& ch = channels[Index(proto::PeerOf(to))];
    ch.due.clear();
    for (Slot& s : ch.slots) {
      if (s.used && s.deliver_ns <= now_ns) ch.due.push_back(&s);  // never beyond the reserved capacity
    }
    std::sort(ch.due.begin(), ch.due.end(), [](const Slot* a, const Slot* b) {
      return a->deliver_ns != b->deliver_ns ? a->deliver_ns < b->deliver_ns : a->order < b->order;
    });
    for (Slot* s : ch.due) {
      intake.Offer(std::span<const std::uint8_t>(s->bytes.data(), s->size), counters);
      s->used = false;
      ++ch.stats.delivered;
    }
  }

  EmulatedMediumConfig config;
  std::array<Channel, 2> channels;
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
  return impl_->channels[Index(from)].stats;
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
                "emulated %s->%s (delay %.3f ms, loss %.3f, dup %.3f, reorder %.3f, corrupt %.3f, seed %llu)",
                proto::ToString(local_), proto::ToString(proto::PeerOf(local_)), out.delay_s * 1e3,
                out.loss_probability, out.duplicate_probability, out.reorder_probability, out.corrupt_probability,
                static_cast<unsigned long long>(c.seed));
  return text.data();
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
