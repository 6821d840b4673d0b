#include "teleop/node/process_main.hpp"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <string_view>

#include "teleop/cli_help.hpp"
#include "teleop/config/configuration_limit.hpp"
#include "teleop/config/delay_recheck.hpp"
#include "teleop/config/stability_check.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "teleop/link/link_config.hpp"
#include "teleop/node/command_server.hpp"
#include "teleop/node/connection_watch.hpp"
#include "teleop/node/device_list.hpp"
#include "teleop/node/exit_codes.hpp"
#include "teleop/node/teleop_node.hpp"
#include "teleop/version.hpp"

namespace teleop::node {

namespace {

std::atomic<TeleopNode*> g_running_node{nullptr};

extern "C" void HandleStopSignal(int /*signal*/) {
  if (TeleopNode* node = g_running_node.load()) node->Stop();
}

/// The start-up stability check of this process's own fixture (docs/stability.md, "In the processes"): false when
/// the process must not start. Runs before the device and the link are opened, so a refused start touches nothing.
/// `verdict`: the line it logged (the session record keeps it).
bool StabilityAllowsStart(const config::ProcessConfig& config, bool allow_unstable, std::string& verdict) {
  if (!config.stability.check) {
    verdict = "stability check skipped (stability.check is false in " + config.source_path +
              "): the fixture stiffness is NOT checked against the predicted limit";
    spdlog::warn("{}", verdict);
    return true;
  }
  const config::StabilityReport report = config::CheckProcessStability(config);
  if (!report.applicable()) {
    verdict = config::DescribePass(config, report);
    spdlog::warn("{}", verdict);
    return true;
  }
  if (report.stable()) {
    verdict = config::DescribePass(config, report);
    spdlog::info("{}", verdict);
    return true;
  }
  const std::string failure = config::DescribeFailure(config, report);
  if (!allow_unstable) {
    spdlog::critical("refusing to start: {}; or pass --allow-unstable to start anyway (experiments only)", failure);
    return false;
  }
  verdict = "--allow-unstable: STARTING A CONFIGURATION PREDICTED UNSTABLE: " + failure;
  spdlog::warn("{}", verdict);
  spdlog::warn("--allow-unstable: expect sustained vibration at the fixture; keep a hand on the stop");
  return true;
}

/// Throws teleop::Error when `path` cannot be written (missing folder, no permission, a directory), so that a run
/// is not lost for want of its summary file. An existing file is left as it is; a file created by the probe is
/// removed again.
void CheckWritable(const std::string& path) {
  const bool existed = std::filesystem::exists(path);
  errno = 0;
  std::ofstream probe(path, std::ios::app);
  if (!probe) {
    throw Error("cannot write the summary to " + path + (errno != 0 ? std::string(": ") + std::strerror(errno) : "") +
                " (--summary-json); checked at start-up");
  }
  probe.close();
  if (!existed) std::filesystem::remove(path);
}

/// The text of a file (the config, read again for the session record; it was loaded at start-up).
std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/// The command line (docs/configuration.md, "Command line").
struct Options {
  std::string config_path;
  double duration_s = -1.0;
  std::string summary_json;
  std::string telemetry_csv;
  std::string log_level = "info";
  bool allow_unstable = false;
  std::string key_file;
  std::string command_socket;
  double command_ramp_s = 0.5;
  double connect_timeout_s = 0.0;
  double status_interval_s = 2.0;
};

// CLI::Range lets NaN through (every comparison with NaN is false): "nan" would run forever.
const CLI::Validator kFinite(
    [](std::string& text) {
      return std::isfinite(std::strtod(text.c_str(), nullptr)) ? std::string()
                                                               : "must be a finite number, got '" + text + "'";
    },
    "FINITE");

void AddOptions(CLI::App& app, Options& o) {
  teleop::StandardHelp(app);
  app.add_option("-c,--config", o.config_path, "Process configuration (YAML); see docs/configuration.md")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("-d,--duration", o.duration_s,
                 "Stop after this many seconds (overrides loop.duration_s of the config; 0 = run until "
                 "SIGINT/SIGTERM; default: the config's)")
      ->default_str("")
      ->check(CLI::Range(0.0, 1e6))
      ->check(kFinite);
  app.add_option("--summary-json", o.summary_json, "Also write the end-of-run summary to this file as JSON");
  app.add_option("--telemetry-csv", o.telemetry_csv, "Per-cycle telemetry CSV (overrides telemetry.csv in the config)");
  app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error, critical, off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}));
  app.add_option("--key-file", o.key_file,
                 "Pre-shared key file for link.security.mode psk (overrides link.security.key_file; teleop-keygen "
                 "makes one)");
  app.add_option("--command-socket", o.command_socket,
                 "Serve run-time commands (teleop-ctl) on this Unix socket, mode 0600 (docs/clutch.md)");
  app.add_option("--command-ramp-s", o.command_ramp_s, "Ramp of an accepted stiffness change that names none (s)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--connect-timeout", o.connect_timeout_s,
                 "Give up when no usable sample of the peer came within this many seconds of the first cycle "
                 "(exit status 5; 0 = wait for ever; docs/troubleshooting.md)")
      ->check(CLI::Range(0.0, 1e6))
      ->check(kFinite);
  app.add_option("--status-interval", o.status_interval_s,
                 "While the peer has not connected, print what this process waits for and sees every this many "
                 "seconds (0 = never)")
      ->check(CLI::Range(0.0, 1e6))
      ->check(kFinite);
  app.add_flag("--allow-unstable", o.allow_unstable,
               "Start even when the fixture stiffness is above the predicted stability limit (experiments only; "
               "docs/stability.md)");
  app.add_flag_callback(
      "--list-devices",
      [] {
        std::cout << DescribeDevices() << std::flush;
        throw CLI::Success();
      },
      "List the registered device backends (what they render, their sensors and config keys) and exit");
}

/// The config with the command line's overrides; throws teleop::Error.
config::ProcessConfig LoadConfig(const Options& o, Role role, const std::string& program) {
  config::ProcessConfig config = config::LoadProcessConfig(o.config_path);
  if (config.role != role) {
    throw Error(o.config_path + ": role is '" + ToString(config.role) + "' but this is " + program);
  }
  if (o.duration_s >= 0.0) config.loop.duration_s = o.duration_s;
  if (!o.telemetry_csv.empty()) config.telemetry.csv_path = o.telemetry_csv;
  if (!o.key_file.empty()) {
    if (config.link.security.mode != transport::LinkSecurityMode::kPsk) {
      throw Error("--key-file given, but " + o.config_path + " has link.security.mode " +
                  ToString(config.link.security.mode) + " (the key is used only with mode psk)");
    }
    config.link.security.key_file = o.key_file;
  }
  if (config.link.security.mode == transport::LinkSecurityMode::kInsecure) {
    spdlog::warn(
        "INSECURE LINK (link.security.mode insecure in {}): messages are not authenticated; anyone who can reach "
        "this link can command the device. Benches and closed buses only (docs/security.md)",
        o.config_path);
  }
  return config;
}

/// The connection watch (teleop/node/connection_watch.hpp) of this process; `node` is stopped on a give-up.
std::unique_ptr<ConnectionWatch> MakeConnectionWatch(const config::ProcessConfig& config, const Options& o,
                                                     TeleopNode& node) {
  ConnectionWatch::Config c;
  c.base.role = config.role;
  c.base.transport = config.link.transport;
  c.base.peer_address = config.link.udp.peer_address + ":" + std::to_string(config.link.udp.peer_port);
  c.base.authenticated = config.link.security.mode == transport::LinkSecurityMode::kPsk;
  c.rate_hz = config.loop.rate_hz;
  c.status_interval_s = o.status_interval_s;
  c.connect_timeout_s = o.connect_timeout_s;
  return std::make_unique<ConnectionWatch>(c, [&node] { node.Stop(); });
}

/// What the delay re-check's actions have switched (on its thread only).
struct DelayRecheckState {
  link::LinkConfig::DelayRecheck::OnUnstable on_unstable = link::LinkConfig::DelayRecheck::OnUnstable::kEvent;
  control::PassivityMode configured_passivity = control::PassivityMode::kOff;
  bool passivity_switched_on = false;  ///< on_unstable: passivity switched the controller on; not yet back.
};

/// What the delay re-check decided, done to the node (on the re-check's thread, never the cycle's): a new fixture
/// stiffness through the run-time command API (checked and ramped like `teleop-ctl stiffness`), or, when no fixture is
/// stable at the measured delay, an event only, the command clutch or the passivity controller
/// (link.delay_recheck.on_unstable). Every action is a delay_recheck event (log, DDS, dashboard) and its message a log
/// line.
void ApplyDelayRecheck(TeleopNode& node, DelayRecheckState& state, const config::DelayRecheck::Action& action) {
  using Detail = DelayRecheckDetail;
  using OnUnstable = link::LinkConfig::DelayRecheck::OnUnstable;
  const auto record = [&node](Detail detail, double stiffness_N_per_m) {
    node.RecordCommandEvent(Event::Kind::kDelayRecheck, stiffness_N_per_m, static_cast<std::uint16_t>(detail));
  };
  if (action.failed) {
    spdlog::error("{}", action.message);
    record(Detail::kFailed, node.fixture_stiffness_N_per_m());
    return;
  }
  if (!action.coupling_unstable && state.passivity_switched_on) {
    // Stable at the measured delay again (a slower link with a fixture that helps, or recovered).
    if (node.RequestPassivityMode(state.configured_passivity, Event::Kind::kDelayRecheck,
                                  node.fixture_stiffness_N_per_m(),
                                  static_cast<std::uint16_t>(Detail::kPassivityRestored))) {
      state.passivity_switched_on = false;
      spdlog::info("delay re-check: the coupling is stable at the measured delay again: passivity back to {}",
                   control::ToString(state.configured_passivity));
    }
  }
  if (action.coupling_unstable) {
    if (state.on_unstable == OnUnstable::kPassivity && state.configured_passivity == control::PassivityMode::kOff &&
        !state.passivity_switched_on) {
      if (node.RequestPassivityMode(control::PassivityMode::kObserver, Event::Kind::kDelayRecheck,
                                    node.fixture_stiffness_N_per_m(),
                                    static_cast<std::uint16_t>(Detail::kPassivityOn))) {
        state.passivity_switched_on = true;
        spdlog::error(
            "{}; passivity controller on: observer on this device's port (link.delay_recheck.on_unstable "
            "passivity; back to off when the coupling is stable at the measured delay again)",
            action.message);
      } else {
        spdlog::error("{}; passivity controller NOT switched on: the command ring was full", action.message);
        record(Detail::kFailed, node.fixture_stiffness_N_per_m());
      }
    } else if (state.on_unstable == OnUnstable::kPassivity) {
      spdlog::error("{}; the passivity controller is already on ({})", action.message,
                    state.passivity_switched_on ? "observer, switched on by the re-check"
                                                : control::ToString(state.configured_passivity));
      record(Detail::kCouplingUnstable, node.fixture_stiffness_N_per_m());
    } else if (state.on_unstable == OnUnstable::kDecouple) {
      node.SetClutch(true);
      spdlog::error(
          "{}; decoupled: the command clutch is pressed (link.delay_recheck.on_unstable decouple; "
          "`teleop-ctl clutch off` releases it)",
          action.message);
      record(Detail::kDecoupled, node.fixture_stiffness_N_per_m());
    } else {
      spdlog::error(
          "{}; nothing changed (link.delay_recheck.on_unstable event): lower the law's gains or turn "
          "passivity on (passivity.mode, or link.delay_recheck.on_unstable passivity)",
          action.message);
      record(Detail::kCouplingUnstable, node.fixture_stiffness_N_per_m());
    }
    return;
  }
  // A bound, not a stiffness: the configuration limit's bound stays in force (the fixture is the least of both).
  const TeleopNode::FixtureChange change = node.RequestFixtureStiffnessWithinConfigured(
      TeleopNode::FixtureBound::kDelayRecheck,
      action.recovered ? std::numeric_limits<double>::infinity() : action.fixture_N_per_m, action.ramp_s);
  if (!change.accepted) {
    spdlog::error("{}; the node refused it: {}", action.message, change.message);
    record(Detail::kFailed, node.fixture_stiffness_N_per_m());
    return;
  }
  if (action.recovered) {
    spdlog::info("{}", action.message);
  } else {
    spdlog::warn("{}", action.message);
  }
  record(action.recovered ? Detail::kRecovered : Detail::kSlower, action.fixture_N_per_m);
}

/// The run-time delay re-check (link.delay_recheck; docs/stability.md, "Run-time re-check"); nullptr when off. Its
/// thread reads the node's measured data age (an atomic the cycle stores) and acts through ApplyDelayRecheck.
std::unique_ptr<config::DelayRecheck> MakeDelayRecheck(const config::ProcessConfig& config, TeleopNode& node) {
  const link::LinkConfig::DelayRecheck& r = config.link.delay_recheck;
  if (!r.enabled) return nullptr;
  config::DelayRecheck::Options options;
  options.watch.window_s = r.window_s;
  options.watch.percentile = r.percentile;
  options.watch.trigger_ratio = r.trigger_ratio;
  options.watch.recover_ratio = r.recover_ratio;
  options.watch.recover_hold_s = r.recover_hold_s;
  options.watch.assumed_age_s = 0.0;  // from the config: one period + the link delay the start-up check assumed
  options.watch.capacity = static_cast<std::size_t>(std::ceil(r.window_s / options.poll_period_s)) + 16;
  options.margin = r.margin;
  options.max_force_rate_N_per_s = r.max_force_rate_N_per_s;
  options.max_penetration_m = r.max_penetration_m;
  spdlog::info(
      "delay re-check on: the {:.0f}th percentile of the data age over {} s against {:.1f} ms (the age the start-up "
      "check assumed) x {}",
      r.percentile * 100.0, r.window_s, config::DelayRecheck::AssumedAge_s(config) * 1e3, r.trigger_ratio);
  DelayRecheckState state;
  state.on_unstable = r.on_unstable;
  state.configured_passivity = config.passivity.mode;
  return std::make_unique<config::DelayRecheck>(
      config, options, [&node] { return node.peer_data_age_s(); },
      [&node, state](const config::DelayRecheck::Action& action) mutable { ApplyDelayRecheck(node, state, action); });
}

/// What the configuration limit decided, done to the node (on its thread, never the cycle's): a bound on the
/// fixture stiffness (lifted when back to the configured one), a configuration_limit event and a log line.
void ApplyConfigurationLimit(TeleopNode& node, const config::ConfigurationLimit::Action& action) {
  using Kind = config::ConfigurationLimit::Action::Kind;
  using Detail = ConfigurationLimitDetail;
  const auto record = [&node](Detail detail, double stiffness_N_per_m) {
    node.RecordCommandEvent(Event::Kind::kConfigurationLimit, stiffness_N_per_m, static_cast<std::uint16_t>(detail));
  };
  if (action.kind == Kind::kFailed) {
    spdlog::error("{}", action.message);
    record(Detail::kFailed, node.fixture_stiffness_N_per_m());
    return;
  }
  const bool restored = action.kind == Kind::kRestored;
  const TeleopNode::FixtureChange change = node.RequestFixtureStiffnessWithinConfigured(
      TeleopNode::FixtureBound::kConfigurationLimit,
      restored ? std::numeric_limits<double>::infinity() : action.fixture_N_per_m, action.ramp_s);
  if (!change.accepted) {
    spdlog::error("{}; the node refused it: {}", action.message, change.message);
    record(Detail::kFailed, node.fixture_stiffness_N_per_m());
    return;
  }
  if (action.kind == Kind::kLowered) {
    spdlog::warn("{} ({})", action.message, change.message);
  } else {
    spdlog::info("{} ({})", action.message, change.message);
  }
  record(action.kind == Kind::kLowered  ? Detail::kLowered
         : action.kind == Kind::kRaised ? Detail::kRaised
                                        : Detail::kRestored,
         action.fixture_N_per_m);
}

/// The run-time limit at the device's configuration (device.<backend>.runtime_limit; docs/arms.md, "Stability");
/// nullptr when off or the device has none. Its thread reads the configuration the device's cycle publishes and
/// acts through ApplyConfigurationLimit and TeleopNode::SetFixtureLimit.
std::unique_ptr<config::ConfigurationLimit> MakeConfigurationLimit(const config::ProcessConfig& config,
                                                                   device::Device& device, TeleopNode& node) {
  const device::DeviceBackend* backend = device::FindDevice(config.device.backend);
  if (backend == nullptr || !backend->configuration_limit) return nullptr;
  const device::ConfigurationLimitOptions options = backend->configuration_limit(config.device);
  if (!options.enabled) return nullptr;
  device::ConfigurationMailbox* mailbox = device.configuration_mailbox();
  if (mailbox == nullptr || !backend->configuration_model) {
    throw Error("device." + config.device.backend +
                ".runtime_limit.enabled: this device publishes no configuration; turn it off");
  }
  auto limit = std::make_unique<config::ConfigurationLimit>(
      config, options, backend->configuration_model(config.device),
      [mailbox](device::DeviceConfiguration& out) {
        mailbox->Read(out);
        return out.count > 0;
      },
      [&node](double limit_N_per_m) { node.SetFixtureLimit(limit_N_per_m); },
      [&node](const config::ConfigurationLimit::Action& action) { ApplyConfigurationLimit(node, action); });
  limit->SetConfiguredSource([&node] { return node.accepted_fixture_stiffness_N_per_m(); });
  spdlog::info(
      "configuration limit on: the fixture's limit at the arm's configuration {} times a second; the fixture stays "
      "below (1 - {}) x it (device.{}.runtime_limit)",
      options.rate_hz, options.margin, config.device.backend);
  return limit;
}

/// The summary to stdout and --summary-json; returns the exit status (teleop/node/exit_codes.hpp).
int Report(const RunSummary& summary, const std::string& summary_json) {
  std::cout << FormatSummaryText(summary) << std::flush;
  if (!summary_json.empty()) {
    std::ofstream out(summary_json);
    out << FormatSummaryJson(summary);
    if (!out) throw Error("cannot write the summary to " + summary_json);
  }
  const int status = ExitCodeFor(summary);
  if (status == kExitFaulted) {
    spdlog::error(
        "the run saw a fault (device fault cycles {}, non-finite inputs {}): exit status {}, which a systemd unit "
        "does not restart; find the cause before starting again",
        summary.device_fault_cycles, summary.nonfinite_inputs, status);
  } else if (status == kExitNeverConnected) {
    constexpr std::string_view kPrefix = "NEVER CONNECTED: ";
    std::string_view why = summary.connection;
    if (why.starts_with(kPrefix)) why.remove_prefix(kPrefix.size());
    spdlog::error("the peer never connected (exit status {}): {}", status, why);
  }
  return status;
}

/// Set-up, the run and the report; throws teleop::Error on a set-up failure.
int Run(const Options& o, Role role, const std::string& program) {
  const config::ProcessConfig config = LoadConfig(o, role, program);
  if (!o.summary_json.empty()) CheckWritable(o.summary_json);  // found now, not after the run
  std::string verdict;
  if (!StabilityAllowsStart(config, o.allow_unstable, verdict)) return kExitConfigError;

  auto device = device::MakeDevice(config.device);
  device::Device& device_ref = *device;  // the node owns it from here; the limit's thread reads its mailbox
  auto link = link::MakeLink(config.link, link::ToSender(role));
  TeleopNode node(config, std::move(device), std::move(link), TeleopNode::Unconfigured{});
  // Before Activate: background threads must not inherit the loop's SCHED_FIFO (the check runs there).
  node.AddSink(MakeConnectionWatch(config, o, node));
  node.Configure();
  std::unique_ptr<CommandServer> commands;
  if (!o.command_socket.empty()) {
    commands = std::make_unique<CommandServer>(node, CommandServer::Config{o.command_socket, 0600, o.command_ramp_s});
  }
  std::unique_ptr<config::DelayRecheck> recheck = MakeDelayRecheck(config, node);  // before Activate, as above
  std::unique_ptr<config::ConfigurationLimit> configuration_limit = MakeConfigurationLimit(config, device_ref, node);
  if (configuration_limit) configuration_limit->Start();  // before Activate, as above
  node.Activate();  // real-time settings on this thread, checked, before the device is activated

  g_running_node.store(&node);
  struct sigaction action {};
  action.sa_handler = HandleStopSignal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  // The session record's parts (deploy/teleop-session): what ran, as read at start-up.
  node.SetSessionRecord(std::filesystem::absolute(o.config_path).string(), ReadText(o.config_path), verdict);
  const RunSummary summary = node.Run();
  recheck.reset();  // its thread acts on the node: stopped before the node is gone
  configuration_limit.reset();
  g_running_node.store(nullptr);
  return Report(summary, o.summary_json);
}

}  // namespace

int ProcessMain(int argc, char** argv, Role role) {
  const std::string program = std::string("teleop-") + ToString(role);
  CLI::App app{program + ": the " + ToString(role) +
               " side of a bilateral teleoperator (three-channel law, forbidden-region virtual fixture)"};
  app.set_version_flag("--version", VersionText(program));
  Options options;
  AddOptions(app, options);
  CLI11_PARSE(app, argc, argv);

  spdlog::set_level(spdlog::level::from_str(options.log_level));
  spdlog::set_pattern("[%H:%M:%S.%e] [" + program + "] [%^%l%$] %v");
  try {
    return Run(options, role, program);
  } catch (const Error& e) {
    spdlog::critical("{}", e.what());
    return kExitConfigError;
  } catch (const std::exception& e) {
    spdlog::critical("unexpected error: {}", e.what());
    return kExitUnexpectedError;
  }
}

}  // namespace teleop::node
