#include "teleop/transport/impairment_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

#include "teleop/error.hpp"

namespace teleop::transport {
namespace {

// Delivery order within one instant: slots sort by (due_ns, order). Offers are kOrderStep apart so that an
// overtaking datagram (order - 1) and a duplicate (order + 1) fit between neighbours.
constexpr std::uint64_t kOrderStep = 1024;

// splitmix64: derives the independent stream seeds from the one seed the user gives.
std::uint64_t SplitMix(std::uint64_t& state) noexcept {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// One random stream per impairment, so that a setting of one never shifts another's draws.
enum Stream : std::size_t { kLoss, kBurst, kDuplicate, kReorder, kCorrupt, kCorruptBits, kJitter, kStreams };

struct Slot {
  bool used = false;
  std::int64_t due_ns = 0;
  std::int64_t offered_ns = 0;
  std::uint64_t order = 0;
  std::size_t size = 0;
  std::array<std::uint8_t, ImpairmentModel::kMaxDatagramBytes> bytes{};
};

void Check(bool ok, const std::string& name, const std::string& what) {
  if (!ok) throw Error(name + ": " + what);
}

std::string Fixed(double v, int digits) {
  std::array<char, 64> text{};
  std::snprintf(text.data(), text.size(), "%.*f", digits, v);
  return text.data();
}

void CheckProbability(double p, const std::string& name, const char* key) {
  Check(p >= 0.0 && p <= 1.0, name, std::string(key) + " must be in [0, 1], got " + std::to_string(p));
}

void CheckTime(double t, const std::string& name, const char* key) {
  Check(std::isfinite(t) && t >= 0.0, name, std::string(key) + " must be finite and >= 0, got " + std::to_string(t));
}

std::int64_t ToNs(double s) noexcept { return std::llround(s * 1e9); }

}  // namespace

struct ImpairmentModel::Impl {
  Impl(const ImpairmentConfig& c, std::uint64_t s, const std::string& name) : config(c), seed(s) {
    CheckTime(c.delay_s, name, "delay_s");
    CheckTime(c.jitter_s, name, "jitter_s");
    CheckProbability(c.loss_probability, name, "loss_probability");
    CheckProbability(c.duplicate_probability, name, "duplicate_probability");
    CheckProbability(c.reorder_probability, name, "reorder_probability");
    CheckProbability(c.corrupt_probability, name, "corrupt_probability");
    CheckProbability(c.burst.enter_probability, name, "burst.enter_probability");
    CheckProbability(c.burst.exit_probability, name, "burst.exit_probability");
    CheckProbability(c.burst.loss_probability, name, "burst.loss_probability");
    Check(c.burst.enter_probability == 0.0 || c.burst.exit_probability > 0.0, name,
          "burst.exit_probability must be > 0 when bursts are on (a burst would never end)");
    Check(c.capacity >= 1 && c.capacity <= 1 << 16, name,
          "capacity must be 1..65536, got " + std::to_string(c.capacity));
    Check(std::isfinite(c.bandwidth_bit_per_s) && c.bandwidth_bit_per_s >= 0.0, name,
          "bandwidth_bit_per_s must be finite and >= 0 (0 = unlimited), got " + std::to_string(c.bandwidth_bit_per_s));
    CheckTime(c.queue_limit_s, name, "queue_limit_s");
    for (const Outage& o : c.outages) {
      CheckTime(o.start_s, name, "outage start_s");
      Check(std::isfinite(o.duration_s) && o.duration_s > 0.0, name,
            "outage duration_s must be finite and > 0, got " + std::to_string(o.duration_s));
      outages_ns.push_back({ToNs(o.start_s), ToNs(o.start_s) + ToNs(o.duration_s)});
    }
    std::int64_t previous_ns = -1;
    for (const DelayStep& step : c.delay_steps) {
      CheckTime(step.at_s, name, "delay step at_s");
      CheckTime(step.delay_s, name, "delay step delay_s");
      Check(ToNs(step.at_s) > previous_ns, name, "delay steps must be in ascending order of at_s");
      previous_ns = ToNs(step.at_s);
      delay_steps_ns.push_back({ToNs(step.at_s), ToNs(step.delay_s)});
    }
    delay_ns = ToNs(c.delay_s);
    jitter_ns = ToNs(c.jitter_s);
    queue_limit_ns = ToNs(c.queue_limit_s);
    std::uint64_t state = seed;
    for (auto& rng : streams) rng.seed(SplitMix(state));
    slots.resize(static_cast<std::size_t>(c.capacity));
    due.reserve(slots.size());
  }

  // Uniform in [0, 1) from the top 53 bits: the same on every standard library (unlike the std distributions).
  double Uniform(Stream s) noexcept { return static_cast<double>(streams[s]() >> 11) * 0x1.0p-53; }
  // Always draws, so that the stream advances once per datagram whatever the probability.
  bool Chance(Stream s, double p) noexcept { return Uniform(s) < p; }

  Slot* FreeSlot() noexcept {
    // Start after the last slot taken: in steady state the next free one is found at once.
    const std::size_t n = slots.size();
    for (std::size_t i = 0; i < n; ++i) {
      Slot& s = slots[(cursor + i) % n];
      if (!s.used) {
        cursor = (cursor + i + 1) % n;
        return &s;
      }
    }
    return nullptr;
  }

  void Corrupt(Slot& slot) noexcept {
    auto& rng = streams[kCorruptBits];
    const int flips = 1 + static_cast<int>(rng() % 3);
    for (int i = 0; i < flips; ++i) {
      const std::uint64_t bit = rng() % (slot.size * 8);
      slot.bytes[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
  }

  bool InOutage(std::int64_t now_ns) const noexcept {
    const std::int64_t t = now_ns - origin_ns;
    return std::any_of(outages_ns.begin(), outages_ns.end(),
                       [t](const std::pair<std::int64_t, std::int64_t>& o) { return t >= o.first && t < o.second; });
  }

  /// The fixed delay at `now_ns`: the last step at or before it, else delay_s.
  std::int64_t DelayAt(std::int64_t now_ns) const noexcept {
    const std::int64_t t = now_ns - origin_ns;
    std::int64_t d = delay_ns;
    for (const auto& [at_ns, step_ns] : delay_steps_ns) {
      if (t < at_ns) break;
      d = step_ns;
    }
    return d;
  }

  Verdict Offer(std::span<const std::uint8_t> bytes, std::int64_t now_ns) noexcept {
    ++counters.offered;
    Slot* slot = !bytes.empty() && bytes.size() <= kMaxDatagramBytes ? FreeSlot() : nullptr;
    if (slot == nullptr) {
      ++counters.dropped_overflow;
      return Verdict::kOverflow;
    }
    // One draw per stream per datagram (see Stream).
    const bool lose = Chance(kLoss, config.loss_probability);
    const bool was_bad = bad;
    bad = was_bad ? !Chance(kBurst, config.burst.exit_probability) : Chance(kBurst, config.burst.enter_probability);
    const bool burst_lose = Chance(kBurst, config.burst.loss_probability) && bad;
    const bool duplicate = Chance(kDuplicate, config.duplicate_probability);
    const bool overtake = Chance(kReorder, config.reorder_probability);
    const bool corrupt = Chance(kCorrupt, config.corrupt_probability);
    const bool corrupt_copy = Chance(kCorrupt, config.corrupt_probability);
    const std::int64_t jitter = jitter_ns > 0 ? std::llround(Uniform(kJitter) * static_cast<double>(jitter_ns)) : 0;
    if (InOutage(now_ns)) {
      ++counters.dropped_outage;
      return Verdict::kDropped;
    }
    if (burst_lose) {
      ++counters.dropped_burst;
      return Verdict::kDropped;
    }
    if (lose) {
      ++counters.dropped_loss;
      return Verdict::kDropped;
    }
    std::int64_t leaves_ns = now_ns;  // when its last bit has left the sender
    if (config.bandwidth_bit_per_s > 0.0) {
      const std::int64_t start_ns = std::max(now_ns, line_free_ns);
      if (start_ns - now_ns > queue_limit_ns) {
        ++counters.dropped_bandwidth;
        return Verdict::kDropped;
      }
      line_free_ns =
          start_ns + std::llround(static_cast<double>(bytes.size()) * 8.0 * 1e9 / config.bandwidth_bit_per_s);
      leaves_ns = line_free_ns;
    }
    // In order: never before the one offered before it (jitter does not reorder).
    const std::int64_t due_ns = std::max(leaves_ns + DelayAt(now_ns) + jitter, last_due_ns);
    last_due_ns = due_ns;
    slot->used = true;
    slot->size = bytes.size();
    std::memcpy(slot->bytes.data(), bytes.data(), bytes.size());
    slot->offered_ns = now_ns;
    slot->due_ns = due_ns;
    slot->order = next_order;
    next_order += kOrderStep;
    const bool predecessor_in_flight = last != nullptr && last->used && last->order == last_order;
    if (overtake && predecessor_in_flight) {
      slot->due_ns = last->due_ns;
      slot->order = last->order - 1;
      ++counters.reordered;
    }
    last = slot;
    last_order = slot->order;
    if (duplicate) {
      Slot* copy = FreeSlot();
      if (copy == nullptr) {
        ++counters.copies_refused;
      } else {
        *copy = *slot;
        copy->order = slot->order + 1;
        ++counters.duplicated;
        if (corrupt_copy) {
          Corrupt(*copy);
          ++counters.corrupted;
        }
      }
    }
    if (corrupt) {
      Corrupt(*slot);
      ++counters.corrupted;
    }
    return Verdict::kQueued;
  }

  void BeginDelivery(std::int64_t now_ns) noexcept {
    due.clear();
    next_due = 0;
    for (Slot& s : slots) {
      if (s.used && s.due_ns <= now_ns) due.push_back(&s);  // never beyond the reserved capacity
    }
    std::sort(due.begin(), due.end(), [](const Slot* a, const Slot* b) {
      return a->due_ns != b->due_ns ? a->due_ns < b->due_ns : a->order < b->order;
    });
  }

  bool NextDelivery(Delivery& out) noexcept {
    if (next_due > 0) due[next_due - 1]->used = false;  // the previous one has been read
    if (next_due >= due.size()) {
      due.clear();
      next_due = 0;
      return false;
    }
    Slot& s = *due[next_due++];
    ++counters.delivered;
    if (s.due_ns > s.offered_ns) ++counters.delayed;
    out.bytes = std::span<const std::uint8_t>(s.bytes.data(), s.size);
    out.due_ns = s.due_ns;
    return true;
  }

  void ReleaseDelivered() noexcept {
    if (next_due > 0) due[next_due - 1]->used = false;
    due.clear();
    next_due = 0;
  }

  ImpairmentConfig config;
  std::uint64_t seed;
  std::array<std::mt19937_64, kStreams> streams;
  std::vector<std::pair<std::int64_t, std::int64_t>> outages_ns;      // [start, end) since origin
  std::vector<std::pair<std::int64_t, std::int64_t>> delay_steps_ns;  // (at, delay) since origin, ascending
  std::int64_t origin_ns = 0;
  std::int64_t delay_ns = 0;
  std::int64_t jitter_ns = 0;
  std::int64_t queue_limit_ns = 0;
  std::int64_t line_free_ns = 0;
  std::int64_t last_due_ns = 0;
  bool bad = false;  // Gilbert–Elliott state
  std::vector<Slot> slots;
  std::size_t cursor = 0;
  std::vector<Slot*> due;  // this delivery's slots, in order; capacity reserved
  std::size_t next_due = 0;
  Slot* last = nullptr;          // the most recently queued slot, while still in flight
  std::uint64_t last_order = 0;  // its order when queued (to detect that the slot was reused)
  std::uint64_t next_order = kOrderStep;
  ImpairmentCounters counters{};
};

ImpairmentModel::ImpairmentModel(const ImpairmentConfig& config, std::uint64_t seed, const std::string& name)
    : impl_(std::make_unique<Impl>(config, seed, name)) {}
ImpairmentModel::~ImpairmentModel() = default;

void ImpairmentModel::Start(std::int64_t origin_ns) noexcept { impl_->origin_ns = origin_ns; }

ImpairmentModel::Verdict ImpairmentModel::Offer(std::span<const std::uint8_t> bytes, std::int64_t now_ns) noexcept {
  impl_->ReleaseDelivered();
  return impl_->Offer(bytes, now_ns);
}

void ImpairmentModel::BeginDelivery(std::int64_t now_ns) noexcept {
  impl_->ReleaseDelivered();
  impl_->BeginDelivery(now_ns);
}

bool ImpairmentModel::NextDelivery(Delivery& out) noexcept { return impl_->NextDelivery(out); }

void ImpairmentModel::Clear() noexcept {
  impl_->ReleaseDelivered();
  for (Slot& s : impl_->slots) s.used = false;
  impl_->last = nullptr;
}

std::size_t ImpairmentModel::in_flight() const noexcept {
  return static_cast<std::size_t>(
      std::count_if(impl_->slots.begin(), impl_->slots.end(), [](const Slot& s) { return s.used; }));
}
const ImpairmentCounters& ImpairmentModel::counters() const noexcept { return impl_->counters; }
const ImpairmentConfig& ImpairmentModel::config() const noexcept { return impl_->config; }
std::uint64_t ImpairmentModel::seed() const noexcept { return impl_->seed; }

std::string ImpairmentModel::Describe() const {
  const ImpairmentConfig& c = impl_->config;
  std::string out = "delay " + Fixed(c.delay_s * 1e3, 3) + " ms";
  for (const DelayStep& step : c.delay_steps) {
    out += ", then " + Fixed(step.delay_s * 1e3, 3) + " ms from " + Fixed(step.at_s, 3) + " s";
  }
  if (c.jitter_s > 0) out += ", jitter " + Fixed(c.jitter_s * 1e3, 3) + " ms";
  if (c.loss_probability > 0) out += ", loss " + Fixed(c.loss_probability, 3);
  if (c.burst.enter_probability > 0) {
    out += ", bursts (enter " + Fixed(c.burst.enter_probability, 4) + ", exit " + Fixed(c.burst.exit_probability, 3) +
           ", loss " + Fixed(c.burst.loss_probability, 3) + ")";
  }
  if (c.duplicate_probability > 0) out += ", dup " + Fixed(c.duplicate_probability, 3);
  if (c.reorder_probability > 0) out += ", reorder " + Fixed(c.reorder_probability, 3);
  if (c.corrupt_probability > 0) out += ", corrupt " + Fixed(c.corrupt_probability, 3);
  if (c.bandwidth_bit_per_s > 0) {
    out += ", bandwidth " + Fixed(c.bandwidth_bit_per_s * 1e-3, 1) + " kbit/s (queue " +
           Fixed(c.queue_limit_s * 1e3, 1) + " ms)";
  }
  if (!c.outages.empty()) out += ", " + std::to_string(c.outages.size()) + " outage(s)";
  return out + ", seed " + std::to_string(impl_->seed);
}

std::string FormatImpairmentCounters(const ImpairmentCounters& c) {
  return "offered " + std::to_string(c.offered) + ", delivered " + std::to_string(c.delivered) +
         ", dropped loss/burst/outage/bandwidth/overflow " + std::to_string(c.dropped_loss) + "/" +
         std::to_string(c.dropped_burst) + "/" + std::to_string(c.dropped_outage) + "/" +
         std::to_string(c.dropped_bandwidth) + "/" + std::to_string(c.dropped_overflow) + ", duplicated " +
         std::to_string(c.duplicated) + ", reordered " + std::to_string(c.reordered) + ", corrupted " +
         std::to_string(c.corrupted) + ", delayed " + std::to_string(c.delayed);
}

std::string ImpairmentCountersJson(const ImpairmentCounters& c) {
  std::string out = "{";
  const auto field = [&out](const char* key, std::uint64_t v, bool last = false) {
    out += std::string("\"") + key + "\": " + std::to_string(v) + (last ? "" : ", ");
  };
  field("offered", c.offered);
  field("delivered", c.delivered);
  field("dropped_loss", c.dropped_loss);
  field("dropped_burst", c.dropped_burst);
  field("dropped_outage", c.dropped_outage);
  field("dropped_bandwidth", c.dropped_bandwidth);
  field("dropped_overflow", c.dropped_overflow);
  field("duplicated", c.duplicated);
  field("copies_refused", c.copies_refused);
  field("reordered", c.reordered);
  field("corrupted", c.corrupted);
  field("delayed", c.delayed, true);
  return out + "}";
}

}  // namespace teleop::transport
