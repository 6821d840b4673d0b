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
#include <memory>

#include "teleop/config/stability_check.hpp"
#include "teleop/config/yaml_config.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "teleop/link/link_config.hpp"
#include "teleop/node/command_server.hpp"
#include "teleop/node/device_list.hpp"
#include "teleop/node/exit_codes.hpp"
#include "teleop/node/teleop_node.hpp"

namespace teleop::node {

namespace {

std::atomic<TeleopNode*> g_running_node{nullptr};

extern "C" void HandleStopSignal(int /*signal*/) {
  if (TeleopNode* node = g_running_node.load()) node->Stop();
}

/// The start-up stability check of this process's own fixture (docs/stability.md, "In the processes"): false when
/// the process must not start. Runs before the device and the link are opened, so a refused start touches nothing.
bool StabilityAllowsStart(const config::ProcessConfig& config, bool allow_unstable) {
  if (!config.stability.check) {
    spdlog::warn(
        "stability check skipped (stability.check is false in {}): the fixture stiffness is NOT checked "
        "against the predicted limit",
        config.source_path);
    return true;
  }
  const config::StabilityReport report = config::CheckProcessStability(config);
  if (!report.applicable()) {
    spdlog::warn("{}", config::DescribePass(config, report));
    return true;
  }
  if (report.stable()) {
    spdlog::info("{}", config::DescribePass(config, report));
    return true;
  }
  const std::string failure = config::DescribeFailure(config, report);
  if (!allow_unstable) {
    spdlog::critical("refusing to start: {}; or pass --allow-unstable to start anyway (experiments only)", failure);
    return false;
  }
  spdlog::warn("--allow-unstable: STARTING A CONFIGURATION PREDICTED UNSTABLE: {}", failure);
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

}  // namespace

int ProcessMain(int argc, char** argv, Role role) {
  const std::string program = std::string("teleop-") + ToString(role);
  CLI::App app{program + ": the " + ToString(role) +
               " side of a bilateral teleoperator (three-channel law, forbidden-region virtual fixture)"};
  std::string config_path;
  double duration_s = -1.0;
  std::string summary_json;
  std::string telemetry_csv;
  std::string log_level = "info";
  bool allow_unstable = false;
  std::string key_file;
  std::string command_socket;
  double command_ramp_s = 0.5;
  app.add_option("-c,--config", config_path, "Process configuration (YAML); see docs/configuration.md")
      ->required()
      ->check(CLI::ExistingFile);
  app.add_option("-d,--duration", duration_s,
                 "Stop after this many seconds (overrides the config; 0 = run until "
                 "SIGINT/SIGTERM)")
      ->check(CLI::Range(0.0, 1e6))
      ->check(CLI::Validator(
          [](std::string& text) {
            // CLI::Range lets NaN through (every comparison with NaN is false): "nan" would run forever.
            return std::isfinite(std::strtod(text.c_str(), nullptr))
                       ? std::string()
                       : "must be a finite number of seconds, got '" + text + "'";
          },
          "FINITE"));
  app.add_option("--summary-json", summary_json, "Also write the end-of-run summary to this file as JSON");
  app.add_option("--telemetry-csv", telemetry_csv, "Per-cycle telemetry CSV (overrides telemetry.csv in the config)");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, critical, off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}));
  app.add_option("--key-file", key_file,
                 "Pre-shared key file for link.security.mode psk (overrides link.security.key_file; teleop-keygen "
                 "makes one)");
  app.add_option("--command-socket", command_socket,
                 "Serve run-time commands (teleop-ctl) on this Unix socket, mode 0600 (docs/clutch.md)");
  app.add_option("--command-ramp-s", command_ramp_s, "Ramp of an accepted stiffness change that names none (s)")
      ->check(CLI::NonNegativeNumber);
  app.add_flag("--allow-unstable", allow_unstable,
               "Start even when the fixture stiffness is above the predicted stability limit (experiments only; "
               "docs/stability.md)");
  app.add_flag_callback(
      "--list-devices",
      [] {
        std::cout << DescribeDevices() << std::flush;
        throw CLI::Success();
      },
      "List the registered device backends (what they render, their sensors and config keys) and exit");
  CLI11_PARSE(app, argc, argv);

  spdlog::set_level(spdlog::level::from_str(log_level));
  spdlog::set_pattern("[%H:%M:%S.%e] [" + program + "] [%^%l%$] %v");

  try {
    config::ProcessConfig config = config::LoadProcessConfig(config_path);
    if (config.role != role) {
      throw Error(config_path + ": role is '" + ToString(config.role) + "' but this is " + program);
    }
    if (duration_s >= 0.0) config.loop.duration_s = duration_s;
    if (!telemetry_csv.empty()) config.telemetry.csv_path = telemetry_csv;
    if (!key_file.empty()) {
      if (config.link.security.mode != transport::LinkSecurityMode::kPsk) {
        throw Error("--key-file given, but " + config_path + " has link.security.mode " +
                    ToString(config.link.security.mode) + " (the key is used only with mode psk)");
      }
      config.link.security.key_file = key_file;
    }
    if (config.link.security.mode == transport::LinkSecurityMode::kInsecure) {
      spdlog::warn(
          "INSECURE LINK (link.security.mode insecure in {}): messages are not authenticated; anyone who can reach "
          "this link can command the device. Benches and closed buses only (docs/security.md)",
          config_path);
    }
    if (!summary_json.empty()) CheckWritable(summary_json);  // found now, not after the run
    if (!StabilityAllowsStart(config, allow_unstable)) return kExitConfigError;

    auto device = device::MakeDevice(config.device);
    auto link = link::MakeLink(config.link, link::ToSender(role));
    TeleopNode node(config, std::move(device), std::move(link), TeleopNode::Unconfigured{});
    node.Configure();
    // Before Activate: the server's thread must not inherit the loop's SCHED_FIFO (the check runs there).
    std::unique_ptr<CommandServer> commands;
    if (!command_socket.empty()) {
      commands = std::make_unique<CommandServer>(node, CommandServer::Config{command_socket, 0600, command_ramp_s});
    }
    node.Activate();  // real-time settings on this thread, checked, before the device is activated

    g_running_node.store(&node);
    struct sigaction action {};
    action.sa_handler = HandleStopSignal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, nullptr);
    sigaction(SIGTERM, &action, nullptr);

    const RunSummary summary = node.Run();
    g_running_node.store(nullptr);

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
    }
    return status;
  } catch (const Error& e) {
    spdlog::critical("{}", e.what());
    return kExitConfigError;
  } catch (const std::exception& e) {
    spdlog::critical("unexpected error: {}", e.what());
    return kExitUnexpectedError;
  }
}

}  // namespace teleop::node
