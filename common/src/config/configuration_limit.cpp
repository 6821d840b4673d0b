#include "teleop/config/configuration_limit.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "teleop/analysis/stability_limit.hpp"
#include "teleop/config/stability_check.hpp"
#include "teleop/error.hpp"
#include "teleop/runtime/background_thread.hpp"

namespace teleop::config {
namespace {

std::string Whole(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f N/m", value);
  return text;
}

std::string Ms(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.0f ms", seconds * 1e3);
  return text;
}

/// The limit search's relative tolerance here (the start-up sweep's ranking): a fixture within it above
/// (1 − margin) × the limit is left as it is, so a configuration drifting by less than the search can tell asks for
/// nothing (a process run lowered 1403 -> 1402 -> 1402 N/m without it).
constexpr double kLimitTolerance = 0.01;

}  // namespace

std::optional<ConfigurationLimit::Action> ConfigurationLimit::Decide(const Options& options, double configured_N_per_m,
                                                                     double current_N_per_m,
                                                                     const Evaluation& evaluation) {
  if (!evaluation.valid) return std::nullopt;
  const double allowed = (1.0 - options.margin) * evaluation.limit_N_per_m;
  Action action;
  action.limit_N_per_m = evaluation.limit_N_per_m;
  if (current_N_per_m > allowed * (1.0 + kLimitTolerance)) {
    action.kind = Action::Kind::kLowered;
    action.fixture_N_per_m = allowed;
  } else if (current_N_per_m < configured_N_per_m) {
    const double raised = std::min(configured_N_per_m, allowed / (1.0 + options.hysteresis));
    if (raised >= configured_N_per_m) {
      action.kind = Action::Kind::kRestored;
      action.fixture_N_per_m = configured_N_per_m;
    } else if (raised >= (1.0 + options.hysteresis) * current_N_per_m && raised > current_N_per_m) {
      action.kind = Action::Kind::kRaised;
      action.fixture_N_per_m = raised;
    } else {
      return std::nullopt;
    }
  } else {
    return std::nullopt;
  }
  action.ramp_s =
      std::abs(action.fixture_N_per_m - current_N_per_m) * options.max_penetration_m / options.max_force_rate_N_per_s;
  const char* what = action.kind == Action::Kind::kLowered  ? "lowered"
                     : action.kind == Action::Kind::kRaised ? "raised"
                                                            : "back to the configured stiffness";
  action.message = "configuration limit: predicted limit " + Whole(evaluation.limit_N_per_m) + " at " +
                   evaluation.at.where + " (apparent mass " + std::to_string(evaluation.at.mass_kg) + " kg, damping " +
                   std::to_string(evaluation.at.damping_Ns_per_m) + " N·s/m along plane " +
                   std::to_string(evaluation.plane) + "'s normal); fixture " + what + ": " + Whole(current_N_per_m) +
                   " -> " + Whole(action.fixture_N_per_m) + " over " + Ms(action.ramp_s) + " (the evaluation took " +
                   Ms(evaluation.elapsed_ms * 1e-3) + ")";
  return action;
}

ConfigurationLimit::ConfigurationLimit(ProcessConfig config, Options options, device::ConfigurationModel model,
                                       std::function<bool(device::DeviceConfiguration&)> read,
                                       std::function<void(double)> publish_limit,
                                       std::function<void(const Action&)> apply)
    : config_(std::move(config)),
      options_(options),
      model_(std::move(model)),
      read_(std::move(read)),
      publish_limit_(std::move(publish_limit)),
      apply_(std::move(apply)) {
  if (!(options_.rate_hz > 0.0) || !(options_.margin >= 0.0 && options_.margin < 1.0) ||
      !(options_.hysteresis >= 0.0) || !(options_.max_force_rate_N_per_s > 0.0) ||
      !(options_.max_penetration_m > 0.0)) {
    throw Error(
        "configuration limit: rate_hz > 0, margin in [0, 1), hysteresis >= 0, max_force_rate_N_per_s and "
        "max_penetration_m > 0");
  }
  if (!model_) throw Error("configuration limit: device '" + config_.device.backend + "' has no configuration model");
  const control::ForbiddenRegionFixture::Config& fixture = config_.law.fixture;
  if (fixture.plane_count == 0 || !(fixture.stiffness_N_per_m > 0.0)) {
    throw Error("configuration limit: the process has no fixture (a stiffness and a plane) to limit");
  }
  humans_ = StabilityOperators(config_);
  for (int p = 0; p < fixture.plane_count; ++p) {
    int axis = 0;
    fixture.planes[static_cast<std::size_t>(p)].normal.cwiseAbs().maxCoeff(&axis);
    plane_models_.push_back(StabilityModel(config_, axis));
  }
  bound_N_per_m_ = std::numeric_limits<double>::infinity();
  const double configured = fixture.stiffness_N_per_m;
  configured_ = [configured] { return configured; };
}

void ConfigurationLimit::SetConfiguredSource(std::function<double()> configured_N_per_m) {
  if (thread_.joinable()) throw Error("configuration limit: SetConfiguredSource() after Start()");
  if (configured_N_per_m) configured_ = std::move(configured_N_per_m);
}

double ConfigurationLimit::fixture_N_per_m() const { return std::min(configured_(), bound_N_per_m_.load()); }

ConfigurationLimit::~ConfigurationLimit() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

ConfigurationLimit::Evaluation ConfigurationLimit::Evaluate(const device::DeviceConfiguration& configuration) {
  const auto start = std::chrono::steady_clock::now();
  Evaluation result;
  const control::ForbiddenRegionFixture::Config& fixture = config_.law.fixture;
  analysis::LimitOptions options;
  options.relative_tolerance = kLimitTolerance;
  options.threads = 1;  // a background thread: never both cores
  for (int p = 0; p < fixture.plane_count; ++p) {
    const device::AnalysisConfiguration at = model_(configuration, fixture.planes[static_cast<std::size_t>(p)].normal);
    if (!std::isfinite(at.mass_kg) || !(at.mass_kg > 0.0)) continue;  // cannot move along n: this plane sets none
    analysis::SampledTeleoperator model = plane_models_[static_cast<std::size_t>(p)];
    (config_.role == Role::kMaster ? model.master : model.slave) = {at.mass_kg, at.damping_Ns_per_m};
    const analysis::StabilityLimit limit =
        analysis::FindMaxStableStiffness(model, FixtureSideOf(config_.role), humans_, options);
    const double value = limit.unstable_without_fixture ? 0.0 : limit.max_stable_stiffness_N_per_m;
    if (!result.valid || value < result.limit_N_per_m) {
      result.valid = true;
      result.limit_N_per_m = value;
      result.plane = p;
      result.at = at;
    }
  }
  result.elapsed_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

bool ConfigurationLimit::Step() {
  device::DeviceConfiguration configuration;
  if (!read_(configuration) || configuration.count == 0) return false;
  try {
    const Evaluation evaluation = Evaluate(configuration);
    ++evaluations_;
    if (evaluation.valid) publish_limit_(evaluation.limit_N_per_m);
    const double configured = configured_();
    const std::optional<Action> action =
        Decide(options_, configured, std::min(configured, bound_N_per_m_.load()), evaluation);
    if (action) {
      bound_N_per_m_ =
          action->kind == Action::Kind::kRestored ? std::numeric_limits<double>::infinity() : action->fixture_N_per_m;
      ++actions_;
      apply_(*action);
    }
    failing_ = false;
  } catch (const std::exception& e) {
    if (failing_) return true;  // reported once per run of failures
    failing_ = true;
    Action failed;
    failed.kind = Action::Kind::kFailed;
    failed.fixture_N_per_m = fixture_N_per_m();
    failed.message = std::string("configuration limit failed: ") + e.what();
    apply_(failed);
  }
  return true;
}

void ConfigurationLimit::Start() {
  if (thread_.joinable()) return;
  thread_ = std::thread([this] { Run(); });
}

void ConfigurationLimit::Run() {
  runtime::BecomeBackgroundThread("teleop-qlimit");  // never the loop's priority or CPU, whoever started it
  const auto period = std::chrono::duration<double>(1.0 / options_.rate_hz);
  std::unique_lock<std::mutex> lock(mutex_);
  while (!wake_.wait_for(lock, period, [this] { return stop_; })) {
    lock.unlock();
    Step();
    lock.lock();
  }
}

}  // namespace teleop::config
