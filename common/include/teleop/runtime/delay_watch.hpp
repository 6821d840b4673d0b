#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace teleop::runtime {

/// Whether the link has become slower than the stability check assumed (issue 32.3, docs/stability.md, "Run-time
/// re-check"). Fed the measured data age of the peer's samples (s) off the real-time thread, it keeps the last
/// `window_s` of them and compares their `percentile` with the data age the check assumed, with hysteresis so that a
/// jittery link does not flip it:
///   - kSlower: the percentile exceeds assumed × trigger_ratio; once slower, again whenever it exceeds the last
///     reported value × trigger_ratio (the link got slower still);
///   - kRecovered: once slower, the percentile has stayed at or below assumed × recover_ratio for recover_hold_s.
/// Not for the real-time thread (it sorts a window); allocation only at construction.
class DelayWatch {
 public:
  struct Config {
    double assumed_age_s = 1e-3;  ///< The data age the check assumed (one period + the link's expected delay).
    double window_s = 1.0;        ///< The percentile is over this much of the newest samples.
    double percentile = 0.99;     ///< 0..1.
    double trigger_ratio = 1.25;  ///< > 1: fire when the percentile exceeds assumed × this.
    double recover_ratio = 1.1;   ///< 1..trigger_ratio: recovered at or below assumed × this ..
    double recover_hold_s = 2.0;  ///< .. held this long.
    std::size_t capacity = 4096;  ///< Samples kept (the window is cut to this many).
  };
  enum class Verdict : std::uint8_t { kNone = 0, kSlower = 1, kRecovered = 2 };

  /// Throws teleop::Error on a non-finite or out-of-range field.
  explicit DelayWatch(const Config& config);

  /// One measured data age (s) at `now_s` (monotonic). Non-finite or negative ages are counted and ignored.
  Verdict Add(double now_s, double age_s);

  bool slower() const noexcept { return slower_; }
  /// The window's percentile after the last Add (s); 0 before any sample.
  double measured_age_s() const noexcept { return measured_s_; }
  /// What the last kSlower reported (s).
  double reported_age_s() const noexcept { return reported_s_; }
  std::uint64_t rejected() const noexcept { return rejected_; }

 private:
  struct Sample {
    double time_s;
    double age_s;
  };
  Config config_;
  std::vector<Sample> ring_;
  std::vector<double> scratch_;
  std::size_t head_ = 0;
  std::size_t size_ = 0;
  bool slower_ = false;
  bool recovering_ = false;
  double recover_since_s_ = 0.0;
  double measured_s_ = 0.0;
  double reported_s_ = 0.0;
  std::uint64_t rejected_ = 0;
};

}  // namespace teleop::runtime
