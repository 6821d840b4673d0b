#include "teleop/config/yaml_config.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>

#include "dds_config.hpp"  // dds: section (docs/dds.md)
#include "sections.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/error.hpp"

// The schema of a process config. Each section has one Parse* function that lists its allowed keys (anything else
// is an error), reads its required and optional keys and checks ranges. A device backend's section is read by the
// backend's own registered reader (teleop/device/device_registry.hpp). Every key is documented in
// docs/configuration.md.

namespace teleop::config {

namespace {

using config::Field;
using config::Map;
using sections::ParseDevice;
using sections::ParseFixture;
using sections::ParseLaw;
using sections::ParseLink;
using sections::ParsePassivity;
using sections::ParseStability;
using sections::ParseTelemetry;

constexpr double kMinRateHz = 250.0;
// UDP runs at 8 kHz; a CAN link is further bounded by its bus-load budget (link.can.max_bus_load).
constexpr double kMaxRateHz = 8000.0;

// ---- sections --------------------------------------------------------------------------------------------------

Role ParseRole(const Field& f) {
  const std::string role = f.AsString();
  if (role == "master") return Role::kMaster;
  if (role == "slave") return Role::kSlave;
  f.Fail("must be 'master' or 'slave', got '" + role + "'");
}

void ParseRealtime(const Field& f, runtime::PeriodicLoopConfig& loop) {
  const Map map(f, {"fifo_priority", "cpu", "lock_memory", "cpu_dma_latency_us"});
  if (auto v = map.Optional("fifo_priority")) loop.fifo_priority = IntInRange(*v, 0, 99);
  if (auto v = map.Optional("cpu")) loop.cpu = IntInRange(*v, -1, 1023);
  if (auto v = map.Optional("lock_memory")) loop.lock_memory = v->AsBool();
  if (auto v = map.Optional("cpu_dma_latency_us")) loop.cpu_dma_latency_us = IntInRange(*v, -1, 1000000);
}

// Phase-locked cycles (docs/configuration.md, `sync`).
void ParseSync(const Field& f, const link::LinkConfig& link, runtime::PeriodicLoopConfig& loop) {
  const Map map(f, {"mode", "timeout_margin_us", "spin_us"});
  if (auto v = map.Optional("mode")) {
    const std::string mode = v->AsString();
    if (mode == "free") {
      loop.sync = runtime::CycleSync::kFree;
    } else if (mode == "triggered") {
      // udp: the master's datagram; can / emulated-can: the master's complete cycle of frames (docs/can.md).
      if (link.emulate.enabled) {
        // The emulated network delivers from its own delay line, not from the socket the trigger waits on.
        v->Fail(
            "'triggered' cannot run with link.emulate (the emulated delay line is not the socket the cycle waits "
            "on); use 'free' with link.emulate");
      }
      loop.sync = runtime::CycleSync::kTriggered;
    } else {
      v->Fail("must be 'free' or 'triggered', got '" + mode + "'");
    }
  }
  if (auto v = map.Optional("timeout_margin_us")) {
    const double period_us = 1e6 / loop.rate_hz;
    const double margin_us = InRange(*v, 1.0, period_us, "µs (at most one period)");
    loop.trigger_timeout_margin_ns = std::llround(margin_us * 1e3);
  }
  if (auto v = map.Optional("spin_us")) {
    const double period_us = 1e6 / loop.rate_hz;
    loop.trigger_spin_ns = std::llround(InRange(*v, 0.0, period_us, "µs (0 = off, at most one period)") * 1e3);
  }
}

ProcessConfig Parse(const YAML::Node& root_node, const std::string& name) {
  const Field root(root_node, "", &name);
  if (root_node.IsNull() || !root_node.IsDefined()) {
    throw Error(name + ": the config is empty; it needs at least role, dof, rate_hz, link, law and device");
  }
  const Map map(root, {"role", "dof", "rate_hz", "duration_s", "realtime", "link", "law", "fixture", "device",
                       "telemetry", "stability", "dds", "passivity", "engagement", "safety", "sync"});
  ProcessConfig config;
  config.source_path = name;
  config.role = ParseRole(map.Required("role"));
  config.dof = IntInRange(map.Required("dof"), 1, kMaxDof);
  config.loop.rate_hz = InRange(map.Required("rate_hz"), kMinRateHz, kMaxRateHz, "Hz");
  if (auto v = map.Optional("duration_s")) config.loop.duration_s = NonNegative(*v, "s (0 = until stopped)");
  if (auto v = map.Optional("realtime")) ParseRealtime(*v, config.loop);

  ParseLink(map.Required("link"), config.role, config.loop.rate_hz, config.dof, config.link);
  if (auto v = map.Optional("sync")) ParseSync(*v, config.link, config.loop);

  config.law.role = config.role;
  config.law.dof = config.dof;
  ParseLaw(map.Required("law"), config.loop.rate_hz, config.law);
  config.law.fixture.dof = config.dof;
  if (auto v = map.Optional("fixture")) ParseFixture(*v, config.dof, config.law.fixture);

  ParseDevice(map.Required("device"), config.role, config.dof, config.device);
  if (auto v = map.Optional("telemetry")) ParseTelemetry(*v, config.telemetry);
  if (auto v = map.Optional("stability")) ParseStability(*v, config.dof, config.stability);
  if (auto v = map.Optional("dds")) detail::ParseDds(*v, config.loop.rate_hz, config.dds);  // docs/dds.md
  // Time-domain passivity (docs/stability.md): absent = off (observe only).
  config.passivity.dof = config.dof;
  config.passivity.max_damping_Ns_per_m = ZeroDof(config.dof);
  if (auto v = map.Optional("passivity")) ParsePassivity(*v, config.dof, config.link, config.passivity);
  if (config.link.delay_recheck.enabled &&
      config.link.delay_recheck.on_unstable == link::LinkConfig::DelayRecheck::OnUnstable::kPassivity &&
      config.passivity.mode == control::PassivityMode::kOff &&
      !(config.passivity.max_damping_Ns_per_m.array() > 0.0).any()) {
    map.self().Fail(
        "link.delay_recheck.on_unstable passivity switches the passivity controller on at run time: give it its "
        "bound, passivity.max_damping_Ns_per_m (N·s/m per DOF, > 0; docs/stability.md), with passivity.mode off");
  }
  config.passivity.max_force_N = config.law.max_force_N;
  config.safety.reaction = sections::DefaultReaction(config.role);
  if (auto v = map.Optional("engagement")) sections::ParseEngagement(*v, config.engagement);
  if (auto v = map.Optional("safety")) sections::ParseSafety(*v, config.role, config.safety);
  return config;
}

}  // namespace

ProcessConfig ParseProcessConfig(const std::string& yaml_text, const std::string& name) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw Error(Located(name, e.mark, "", "YAML syntax error: " + e.msg));
  }
  try {
    return Parse(root, name);
  } catch (const YAML::Exception& e) {
    // Not expected (every access is checked), but never let a yaml-cpp exception escape as something else.
    throw Error(Located(name, e.mark, "", "cannot read the config: " + e.msg));
  }
}

ProcessConfig LoadProcessConfig(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    const int err = errno;
    throw Error("cannot read config file '" + path + "': " + std::system_category().message(err));
  }
  std::stringstream text;
  text << in.rdbuf();
  return ParseProcessConfig(text.str(), path);
}

}  // namespace teleop::config
