#pragma once

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

#include "teleop/config/process_config.hpp"
#include "teleop/runtime/delay_watch.hpp"

namespace teleop::config {

/// Issue 32.3, the run-time re-check: a thread of its own (never the real-time one) samples the measured data age,
/// and when its high percentile exceeds what the start-up check assumed (runtime::DelayWatch, with hysteresis) it
/// waits one window (the watch fires on an age still climbing through a step) and runs the same check again with the
/// percentile then as the measured delay and hands the node a new fixture stiffness, ramped at a bounded
/// force rate; when the link recovers, the configured stiffness again. When no stiffness is stable at the measured
/// delay (the coupling itself is not), `apply` gets the action with coupling_unstable and the fixture is left as it
/// is (the process logs it, decouples or switches passivity on: link.delay_recheck.on_unstable), and the recovery
/// that follows is an action even when the stiffness is already the configured one (the process undoes what it
/// switched). It drives the node only through `apply`
/// (the process passes TeleopNode::RequestFixtureStiffness, the run-time command API the command server uses).
class DelayRecheck {
 public:
  struct Options {
    runtime::DelayWatch::Config watch{};   ///< assumed_age_s: set from the config by the constructor when 0.
    double margin = 0.9;                   ///< The new stiffness is this × the predicted limit at the measured delay.
    double max_force_rate_N_per_s = 20.0;  ///< The ramp's force rate at max_penetration_m (bounds the ramp time).
    double max_penetration_m = 0.01;       ///< The deepest penetration the ramp's force rate is bounded at.
    double poll_period_s = 0.01;           ///< How often the thread samples the data age.
  };
  /// What the re-check decided.
  struct Action {
    double measured_age_s = 0.0;
    double limit_N_per_m = 0.0;      ///< Predicted at the measured delay (0: the coupling itself is unstable).
    double fixture_N_per_m = 0.0;    ///< The stiffness to ramp to.
    double ramp_s = 0.0;             ///< |Δk| × max_penetration_m / max_force_rate_N_per_s.
    bool recovered = false;          ///< Back to the configured stiffness.
    bool coupling_unstable = false;  ///< No stiffness is stable: the law's gains need lowering or passivity on.
    bool failed = false;             ///< The re-check threw (message says why); nothing to apply.
    std::string message;             ///< For the event log.
  };

  /// The data age the start-up check assumed: one period + AssumedLinkDelay_s(config).
  static double AssumedAge_s(const ProcessConfig& config) noexcept;
  /// The check with a measured data age (s) in place of the assumed one; `current_N_per_m` the fixture now.
  static Action Evaluate(const ProcessConfig& config, const Options& options, double measured_age_s,
                         double current_N_per_m);

  /// Starts the thread. `data_age_s` returns the newest measured data age (s; < 0 when none). Both callbacks run on
  /// the re-check's thread. Throws teleop::Error on bad options.
  DelayRecheck(ProcessConfig config, Options options, std::function<double()> data_age_s,
               std::function<void(const Action&)> apply);
  ~DelayRecheck();
  DelayRecheck(const DelayRecheck&) = delete;
  DelayRecheck& operator=(const DelayRecheck&) = delete;

  int actions() const noexcept { return actions_.load(); }

 private:
  void Run();

  ProcessConfig config_;
  Options options_;
  std::function<double()> data_age_s_;
  std::function<void(const Action&)> apply_;
  runtime::DelayWatch watch_;
  double current_N_per_m_ = 0.0;
  bool unstable_reported_ = false;  ///< The last action found the coupling unstable: a recovery is an action.
  std::atomic<int> actions_{0};
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace teleop::config
