#pragma once

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "teleop/analysis/teleoperator_model.hpp"
#include "teleop/config/process_config.hpp"
#include "teleop/device/device_configuration.hpp"
#include "teleop/device/device_registry.hpp"

namespace teleop::config {

/// Issue 28.5, the run-time part: the fixture's stability limit at the device's current configuration (an arm's
/// apparent mass and damping along each fixture plane's normal change with q; docs/arms.md, "Stability"). A thread
/// of its own (never the real-time one) reads the configuration the cycle publishes (device::ConfigurationMailbox),
/// evaluates the device along every plane's normal there (device::ConfigurationModel), and finds the limit with the
/// start-up check's model of the process (StabilityModel with the configuration's mass and damping, the gains of the
/// axis the normal is closest to, its operator set; ranked to 1 % as the sweep ranks its buckets). It publishes the
/// smallest limit over the planes, and when the fixture is stiffer than (1 − margin) × that limit, hands the node a
/// lower stiffness, ramped at a bounded force rate; when the configuration leaves that region, a higher one again
/// (with hysteresis), up to the configured stiffness. It acts only through its callbacks (the process passes
/// TeleopNode::RequestFixtureStiffnessWithinConfigured and TeleopNode::SetFixtureLimit).
class ConfigurationLimit {
 public:
  using Options = device::ConfigurationLimitOptions;

  /// The limit at one configuration.
  struct Evaluation {
    bool valid = false;                ///< False: no plane could be analysed there (immobile along every normal).
    double limit_N_per_m = 0.0;        ///< The smallest over the planes (0: the coupling itself is unstable there).
    int plane = 0;                     ///< The plane it belongs to.
    device::AnalysisConfiguration at;  ///< The device along that plane's normal.
    double elapsed_ms = 0.0;           ///< Wall time of the evaluation.
  };
  /// What the limit decided.
  struct Action {
    enum class Kind : std::uint8_t { kLowered, kRaised, kRestored, kFailed };
    Kind kind = Kind::kLowered;
    double limit_N_per_m = 0.0;    ///< The limit at the configuration.
    double fixture_N_per_m = 0.0;  ///< The stiffness to ramp to.
    double ramp_s = 0.0;           ///< |Δk| × max_penetration_m / max_force_rate_N_per_s.
    std::string message;           ///< For the log.
  };

  /// The decision (no I/O): with the fixture now at `current_N_per_m` and `configured_N_per_m` the stiffness it
  /// may not exceed, lowered to (1 − margin) × limit when it is above it by more than the limit search's 1 %; raised
  /// (while below the configured one) to min(configured, (1 − margin) × limit / (1 + hysteresis)) when that is at least
  /// (1 + hysteresis) × current, or when it reaches the configured one (kRestored). Nothing when neither holds or the
  /// evaluation is not valid.
  static std::optional<Action> Decide(const Options& options, double configured_N_per_m, double current_N_per_m,
                                      const Evaluation& evaluation);

  /// Set-up: checks the options and builds the analysis' model of `config` (throws teleop::Error naming what is
  /// wrong: a device without a configuration model, no fixture plane, an option out of range). `read` copies the
  /// newest published configuration and says whether there is one; `publish_limit` gets every evaluated limit
  /// (N/m); `apply` every action. The callbacks run on the limit's thread. No thread until Start().
  ConfigurationLimit(ProcessConfig config, Options options, device::ConfigurationModel model,
                     std::function<bool(device::DeviceConfiguration&)> read,
                     std::function<void(double limit_N_per_m)> publish_limit, std::function<void(const Action&)> apply);
  ~ConfigurationLimit();
  ConfigurationLimit(const ConfigurationLimit&) = delete;
  ConfigurationLimit& operator=(const ConfigurationLimit&) = delete;

  /// The limit at `configuration` (the thread's work; tests call it directly). Throws teleop::Error.
  Evaluation Evaluate(const device::DeviceConfiguration& configuration);
  /// One round: read, evaluate, publish, decide, apply. False when nothing was published yet. What the thread runs
  /// at options.rate_hz (tests call it directly, without Start()); an exception becomes a kFailed action.
  bool Step();
  /// Starts the thread (background priority, never the loop's CPU). Once.
  void Start();
  /// Where the stiffness the fixture may not exceed comes from (the process: the node's accepted stiffness, which a
  /// `teleop-ctl stiffness` command changes); absent: the config's law.fixture.stiffness_N_per_m. Before Start().
  void SetConfiguredSource(std::function<double()> configured_N_per_m);

  /// The fixture stiffness as this limit leaves it: min(the configured one, its bound; +inf until it acts).
  double fixture_N_per_m() const;
  int evaluations() const noexcept { return evaluations_.load(); }
  int actions() const noexcept { return actions_.load(); }

 private:
  void Run();

  ProcessConfig config_;
  Options options_;
  device::ConfigurationModel model_;
  std::function<bool(device::DeviceConfiguration&)> read_;
  std::function<void(double)> publish_limit_;
  std::function<void(const Action&)> apply_;
  std::vector<analysis::HumanModel> humans_;
  std::vector<analysis::SampledTeleoperator> plane_models_;  ///< Per plane: the process's model, gains of its axis.
  std::function<double()> configured_;
  std::atomic<double> bound_N_per_m_{0.0};  ///< +inf: none (set by the constructor).
  std::atomic<int> evaluations_{0};
  std::atomic<int> actions_{0};
  bool failing_ = false;  ///< The last Step failed (a run of failures is reported once).
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace teleop::config
