#include "teleop/config/delay_recheck.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <utility>

#include "teleop/config/stability_check.hpp"
#include "teleop/error.hpp"
#include "teleop/runtime/background_thread.hpp"

namespace teleop::config {
namespace {

std::string Ms(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f ms", seconds * 1e3);
  return text;
}

std::string Whole(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f N/m", value);
  return text;
}

runtime::DelayWatch::Config WatchFor(const ProcessConfig& config, runtime::DelayWatch::Config watch) {
  if (watch.assumed_age_s <= 0.0) watch.assumed_age_s = DelayRecheck::AssumedAge_s(config);
  return watch;
}

}  // namespace

double DelayRecheck::AssumedAge_s(const ProcessConfig& config) noexcept {
  return 1.0 / config.loop.rate_hz + AssumedLinkDelay_s(config);
}

DelayRecheck::Action DelayRecheck::Evaluate(const ProcessConfig& config, const Options& options, double measured_age_s,
                                            double current_N_per_m) {
  Action action;
  action.measured_age_s = measured_age_s;
  ProcessConfig at_measured = config;
  at_measured.link.expected_delay_ms = std::max(0.0, measured_age_s - 1.0 / config.loop.rate_hz) * 1e3;
  const StabilityReport report = CheckProcessStability(at_measured);
  const double configured = config.law.fixture.stiffness_N_per_m;
  if (!report.applicable()) {
    action.fixture_N_per_m = current_N_per_m;
    action.message = "delay re-check: data age " + Ms(measured_age_s) + ", the check does not apply (" +
                     report.not_applicable + "): fixture left as it is";
    return action;
  }
  const analysis::FixtureCheck& worst = report.worst();
  action.coupling_unstable = worst.limit.unstable_without_fixture;
  action.limit_N_per_m = action.coupling_unstable ? 0.0 : worst.limit.max_stable_stiffness_N_per_m;
  action.fixture_N_per_m = std::min(configured, options.margin * action.limit_N_per_m);
  action.ramp_s =
      std::abs(current_N_per_m - action.fixture_N_per_m) * options.max_penetration_m / options.max_force_rate_N_per_s;
  action.message =
      "delay re-check: data age " + Ms(measured_age_s) + " (the check assumed " + Ms(AssumedAge_s(config)) +
      "): predicted limit " +
      (action.coupling_unstable ? std::string("none, the coupling itself is unstable") : Whole(action.limit_N_per_m)) +
      "; fixture " + Whole(current_N_per_m) + " -> " + Whole(action.fixture_N_per_m) + " over " + Ms(action.ramp_s) +
      " (" + AnalyzeCommandLine(at_measured, report.worst_axis()) + ")";
  return action;
}

DelayRecheck::DelayRecheck(ProcessConfig config, Options options, std::function<double()> data_age_s,
                           std::function<void(const Action&)> apply)
    : config_(std::move(config)),
      options_(options),
      data_age_s_(std::move(data_age_s)),
      apply_(std::move(apply)),
      watch_(WatchFor(config_, options.watch)) {
  if (!(options_.margin > 0.0 && options_.margin <= 1.0) || !(options_.max_force_rate_N_per_s > 0.0) ||
      !(options_.max_penetration_m > 0.0) || !(options_.poll_period_s > 0.0)) {
    throw Error(
        "delay re-check: margin must be in (0, 1], max_force_rate_N_per_s, max_penetration_m and "
        "poll_period_s > 0");
  }
  current_N_per_m_ = config_.law.fixture.stiffness_N_per_m;
  thread_ = std::thread([this] { Run(); });
}

DelayRecheck::~DelayRecheck() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void DelayRecheck::Run() {
  runtime::BecomeBackgroundThread("teleop-recheck");  // never the loop's priority or CPU, whoever started it
  const auto start = std::chrono::steady_clock::now();
  const auto period = std::chrono::duration<double>(options_.poll_period_s);
  // The watch fires as the percentile crosses its threshold, i.e. on an age still climbing through a step (a step
  // up leaves no arrival for its size, then every sample has the new age): the check waits one window after the
  // first trigger and runs with the percentile then, which holds only the new ages when the step persists.
  bool settling = false;
  double settled_at_s = 0.0;
  std::unique_lock<std::mutex> lock(mutex_);
  while (!wake_.wait_for(lock, period, [this] { return stop_; })) {
    lock.unlock();
    const double age_s = data_age_s_();
    const double now_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    runtime::DelayWatch::Verdict verdict =
        age_s >= 0.0 ? watch_.Add(now_s, age_s) : runtime::DelayWatch::Verdict::kNone;
    if (verdict == runtime::DelayWatch::Verdict::kSlower && !settling) {
      settling = true;
      settled_at_s = now_s + options_.watch.window_s;
    }
    if (verdict == runtime::DelayWatch::Verdict::kRecovered) settling = false;
    if (verdict == runtime::DelayWatch::Verdict::kSlower) verdict = runtime::DelayWatch::Verdict::kNone;
    if (settling && now_s >= settled_at_s) {
      settling = false;
      if (watch_.slower()) verdict = runtime::DelayWatch::Verdict::kSlower;
    }
    try {
      if (verdict == runtime::DelayWatch::Verdict::kSlower) {
        const Action action = Evaluate(config_, options_, watch_.measured_age_s(), current_N_per_m_);
        if (action.coupling_unstable) {
          // No stiffness helps: the fixture is left as it is (the caller decides: an event, decouple, or passivity
          // on); the recovery that follows is an action, so the caller can undo what it switched.
          unstable_reported_ = true;
          ++actions_;
          apply_(action);
        } else if (action.fixture_N_per_m < current_N_per_m_) {
          unstable_reported_ = false;
          current_N_per_m_ = action.fixture_N_per_m;
          ++actions_;
          apply_(action);
        }
      } else if (verdict == runtime::DelayWatch::Verdict::kRecovered) {
        Action action;
        action.recovered = true;
        action.measured_age_s = watch_.measured_age_s();
        action.fixture_N_per_m = config_.law.fixture.stiffness_N_per_m;
        action.ramp_s = std::abs(action.fixture_N_per_m - current_N_per_m_) * options_.max_penetration_m /
                        options_.max_force_rate_N_per_s;
        action.message = "delay re-check: the link recovered (data age " + Ms(action.measured_age_s) +
                         "): fixture back to " + Whole(action.fixture_N_per_m) + " over " + Ms(action.ramp_s);
        if (action.fixture_N_per_m != current_N_per_m_ || unstable_reported_) {
          unstable_reported_ = false;
          current_N_per_m_ = action.fixture_N_per_m;
          ++actions_;
          apply_(action);
        }
      }
    } catch (const std::exception& e) {
      Action failed;
      failed.measured_age_s = watch_.measured_age_s();
      failed.fixture_N_per_m = current_N_per_m_;
      failed.failed = true;
      failed.message = std::string("delay re-check failed: ") + e.what();
      apply_(failed);
    }
    lock.lock();
  }
}

}  // namespace teleop::config
