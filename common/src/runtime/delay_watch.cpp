#include "teleop/runtime/delay_watch.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "teleop/error.hpp"

namespace teleop::runtime {

DelayWatch::DelayWatch(const Config& config) : config_(config) {
  const auto bad = [](const char* field, double value, const char* requirement) {
    throw Error("delay watch: " + std::string(field) + " = " + std::to_string(value) + " " + requirement);
  };
  if (!std::isfinite(config.assumed_age_s) || config.assumed_age_s <= 0.0) {
    bad("assumed_age_s", config.assumed_age_s, "must be > 0");
  }
  if (!std::isfinite(config.window_s) || config.window_s <= 0.0) bad("window_s", config.window_s, "must be > 0");
  if (!(config.percentile > 0.0 && config.percentile <= 1.0)) bad("percentile", config.percentile, "must be in (0, 1]");
  if (!(config.trigger_ratio > 1.0) || !std::isfinite(config.trigger_ratio)) {
    bad("trigger_ratio", config.trigger_ratio, "must be > 1");
  }
  if (!(config.recover_ratio >= 1.0 && config.recover_ratio <= config.trigger_ratio)) {
    bad("recover_ratio", config.recover_ratio, "must be in 1..trigger_ratio (the hysteresis band)");
  }
  if (!std::isfinite(config.recover_hold_s) || config.recover_hold_s < 0.0) {
    bad("recover_hold_s", config.recover_hold_s, "must be >= 0");
  }
  if (config.capacity < 1) bad("capacity", 0.0, "must be >= 1");
  ring_.resize(config.capacity);
  scratch_.reserve(config.capacity);
}

DelayWatch::Verdict DelayWatch::Add(double now_s, double age_s) {
  if (!std::isfinite(age_s) || age_s < 0.0 || !std::isfinite(now_s)) {
    ++rejected_;
    return Verdict::kNone;
  }
  ring_[head_] = {now_s, age_s};
  head_ = (head_ + 1) % ring_.size();
  size_ = std::min(size_ + 1, ring_.size());
  scratch_.clear();
  for (std::size_t i = 0; i < size_; ++i) {
    const Sample& s = ring_[(head_ + ring_.size() - 1 - i) % ring_.size()];
    if (now_s - s.time_s > config_.window_s) break;
    scratch_.push_back(s.age_s);
  }
  const auto rank = static_cast<std::size_t>(std::ceil(config_.percentile * static_cast<double>(scratch_.size()))) - 1;
  const auto nth = scratch_.begin() + static_cast<std::ptrdiff_t>(std::min(rank, scratch_.size() - 1));
  std::nth_element(scratch_.begin(), nth, scratch_.end());
  measured_s_ = *nth;

  const double trigger_s = (slower_ ? reported_s_ : config_.assumed_age_s) * config_.trigger_ratio;
  if (measured_s_ > trigger_s) {
    slower_ = true;
    recovering_ = false;
    reported_s_ = measured_s_;
    return Verdict::kSlower;
  }
  if (!slower_) return Verdict::kNone;
  if (measured_s_ > config_.assumed_age_s * config_.recover_ratio) {
    recovering_ = false;
    return Verdict::kNone;
  }
  if (!recovering_) {
    recovering_ = true;
    recover_since_s_ = now_s;
  }
  if (now_s - recover_since_s_ < config_.recover_hold_s) return Verdict::kNone;
  slower_ = false;
  recovering_ = false;
  reported_s_ = 0.0;
  return Verdict::kRecovered;
}

}  // namespace teleop::runtime
