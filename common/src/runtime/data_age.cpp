#include "teleop/runtime/data_age.hpp"

#include <algorithm>

namespace teleop::runtime {

void DataAgeTracker::OnNewSample(std::int64_t receive_ns, std::int64_t sent_local_ns, bool triggered) noexcept {
  receive_ns_ = receive_ns;
  sent_local_ns_ = sent_local_ns;
  cycles_old_ = triggered ? 0 : 1;
  have_sample_ = true;
}

void DataAgeTracker::OnCycle(std::int64_t cycle_start_ns, bool used) noexcept {
  if (!have_sample_) return;
  if (used) {
    receive_age_ns_.Add(cycle_start_ns - receive_ns_);
    if (sent_local_ns_ != 0) sender_age_ns_.Add(cycle_start_ns - sent_local_ns_);
    ++age_cycles_[std::min<std::size_t>(cycles_old_, kCycleBuckets - 1)];
  }
  ++cycles_old_;
}

int DataAgeTracker::MedianAgeCycles() const noexcept {
  std::uint64_t total = 0;
  for (const std::uint64_t n : age_cycles_) total += n;
  if (total == 0) return -1;
  std::uint64_t seen = 0;
  for (std::size_t i = 0; i < kCycleBuckets; ++i) {
    seen += age_cycles_[i];
    if (2 * seen >= total) return static_cast<int>(i);
  }
  return static_cast<int>(kCycleBuckets - 1);
}

}  // namespace teleop::runtime
