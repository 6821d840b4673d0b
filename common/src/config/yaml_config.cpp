#include "teleop/config/yaml_config.hpp"

#include <arpa/inet.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <system_error>

#include "dds_config.hpp"  // dds: section (docs/dds.md)
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"

// The schema of a process config. Each section has one Parse* function that lists its allowed keys (anything else
// is an error), reads its required and optional keys and checks ranges. A device backend's section is read by the
// backend's own registered reader (teleop/device/device_registry.hpp). Every key is documented in
// docs/configuration.md.

namespace teleop::config {

namespace {

using config::Field;
using config::Map;

constexpr double kMinRateHz = 250.0;
constexpr double kMaxRateHz = 4000.0;

// ---- sections --------------------------------------------------------------------------------------------------

Role ParseRole(const Field& f) {
  const std::string role = f.AsString();
  if (role == "master") return Role::kMaster;
  if (role == "slave") return Role::kSlave;
  f.Fail("must be 'master' or 'slave', got '" + role + "'");
}

void ParseRealtime(const Field& f, runtime::PeriodicLoopConfig& loop) {
  const Map map(f, {"fifo_priority", "cpu", "lock_memory"});
  if (auto v = map.Optional("fifo_priority")) loop.fifo_priority = IntInRange(*v, 0, 99);
  if (auto v = map.Optional("cpu")) loop.cpu = IntInRange(*v, -1, 1023);
  if (auto v = map.Optional("lock_memory")) loop.lock_memory = v->AsBool();
}

struct Endpoint {
  std::string address;
  std::uint16_t port = 0;
};

/// "A.B.C.D:PORT" or "[IPv6]:PORT", numeric addresses only (the link does not resolve host names).
Endpoint ParseEndpoint(const Field& f) {
  const std::string text = f.AsString();
  const auto hint = [&](const std::string& why) {
    f.Fail(why + " in '" + text + "'; expected \"IPv4:PORT\" like \"127.0.0.1:47001\" or \"[IPv6]:PORT\"");
  };
  const std::size_t colon = text.rfind(':');
  if (colon == std::string::npos) hint("no port");
  std::string host = text.substr(0, colon);
  const std::string port_text = text.substr(colon + 1);
  bool v6 = false;
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
    v6 = true;
  }
  unsigned char buffer[16];
  if (host.empty() || inet_pton(v6 ? AF_INET6 : AF_INET, host.c_str(), buffer) != 1) {
    hint("'" + host + "' is not a numeric " + std::string(v6 ? "IPv6" : "IPv4") + " address");
  }
  if (port_text.empty() || port_text.size() > 5 || port_text.find_first_not_of("0123456789") != std::string::npos) {
    hint("port '" + port_text + "' is not a number");
  }
  const int port = std::stoi(port_text);
  if (port < 1 || port > 65535) hint("port " + std::to_string(port) + " is outside 1..65535");
  return {host, static_cast<std::uint16_t>(port)};
}

// The `link.can` section (docs/can.md): used by transport "can" (SocketCAN) and "emulated-can" (teleop-canbus).
void ParseCan(const Field& f, bool emulated, transport::CanLinkConfig& can) {
  const Map map(
      f, {"interface", "bus", "fd", "bit_rate_switch", "nominal_bitrate_bit_per_s", "data_bitrate_bit_per_s",
          "extended_id", "master_to_slave_base_id", "slave_to_master_base_id", "max_bus_load", "connect_timeout_ms"});
  if (auto v = map.Optional("interface")) {
    can.interface_name = v->AsString();
    if (can.interface_name.empty() || can.interface_name.size() > 15) {
      v->Fail("must be a network interface name of 1..15 characters (e.g. can0, vcan0), got '" + can.interface_name +
              "'");
    }
  } else if (!emulated) {
    map.Required("interface");  // fails with the key's name
  }
  if (auto v = map.Optional("bus")) {
    if (!emulated) v->Fail("only for transport emulated-can (the teleop-canbus daemon's address)");
    const Endpoint bus = ParseEndpoint(*v);
    can.emulated_bus_host = bus.address;
    can.emulated_bus_port = bus.port;
  }
  if (auto v = map.Optional("fd")) can.fd = v->AsBool();
  if (auto v = map.Optional("bit_rate_switch")) can.bit_rate_switch = v->AsBool();
  if (auto v = map.Optional("nominal_bitrate_bit_per_s")) {
    can.nominal_bitrate_bit_per_s = InRange(*v, 10'000.0, 1'000'000.0, "bit/s");
  }
  if (auto v = map.Optional("data_bitrate_bit_per_s")) {
    can.data_bitrate_bit_per_s = InRange(*v, 10'000.0, 12'000'000.0, "bit/s");
  }
  if (auto v = map.Optional("extended_id")) can.extended_id = v->AsBool();
  const int max_id = can.extended_id ? 0x1FFFFFFF : 0x7FF;
  const auto base_id = [max_id](const Field& e) {
    // Each direction uses base .. base + 4 (docs/can.md).
    return static_cast<std::uint32_t>(IntInRange(e, 0, max_id - 4));
  };
  if (auto v = map.Optional("master_to_slave_base_id")) can.master_to_slave_base_id = base_id(*v);
  if (auto v = map.Optional("slave_to_master_base_id")) can.slave_to_master_base_id = base_id(*v);
  const auto lo = std::min(can.master_to_slave_base_id, can.slave_to_master_base_id);
  const auto hi = std::max(can.master_to_slave_base_id, can.slave_to_master_base_id);
  if (hi - lo < 5) {
    f.Fail(
        "master_to_slave_base_id and slave_to_master_base_id must be at least 5 apart (each direction uses "
        "base .. base + 4)");
  }
  if (auto v = map.Optional("max_bus_load")) {
    can.max_bus_load = InRange(*v, 0.01, 1.0, "(fraction of bus time)");
  }
  if (auto v = map.Optional("connect_timeout_ms")) can.connect_timeout_ms = Positive(*v, "ms");
}

void ParseLink(const Field& f, Role role, double rate_hz, int dof, transport::LinkConfig& link) {
  const Map map(f,
                {"transport", "bind", "peer", "timeout_ms", "accept_only_peer_address", "receive_buffer_bytes", "can"});
  if (auto v = map.Optional("transport")) {
    link.transport = v->AsString();
    if (link.transport != "udp" && link.transport != "can" && link.transport != "emulated-can") {
      v->Fail("unsupported transport '" + link.transport + "'; known: udp, can, emulated-can");
    }
  }
  link.rate_hz = rate_hz;
  link.can.dof = dof;
  if (link.transport == "udp") {
    if (auto v = map.Optional("can")) v->Fail("only for transport can or emulated-can");
    const Field bind_field = map.Required("bind");
    const Field peer_field = map.Required("peer");
    const Endpoint bind = ParseEndpoint(bind_field);
    const Endpoint peer = ParseEndpoint(peer_field);
    if (bind.address == peer.address && bind.port == peer.port) {
      peer_field.Fail("the peer is the same endpoint as bind; the other process must listen on another port");
    }
    if ((bind.address.find(':') != std::string::npos) != (peer.address.find(':') != std::string::npos)) {
      peer_field.Fail("bind and peer must both be IPv4 or both IPv6");
    }
    link.udp.bind_address = bind.address;
    link.udp.bind_port = bind.port;
    link.udp.peer_address = peer.address;
    link.udp.peer_port = peer.port;
  } else {
    for (const char* udp_only : {"bind", "peer", "accept_only_peer_address", "receive_buffer_bytes"}) {
      if (auto v = map.Optional(udp_only)) v->Fail("only for transport udp");
    }
    const bool emulated = link.transport == "emulated-can";
    link.can.medium = emulated ? transport::CanMedium::kEmulatedBus : transport::CanMedium::kSocketCan;
    if (auto v = map.Optional("can")) {
      ParseCan(*v, emulated, link.can);
    } else if (!emulated) {
      map.Required("can");  // SocketCAN needs at least the interface name
    }
  }
  link.udp.expected_peer = role == Role::kMaster ? proto::SenderRole::kSlave : proto::SenderRole::kMaster;
  if (auto v = map.Optional("timeout_ms")) {
    link.timeout_ms = Positive(*v, "ms");
    const double period_ms = 1000.0 / rate_hz;
    if (link.timeout_ms < period_ms) {
      v->Fail("must be at least one loop period (" + Num(period_ms) + " ms at rate_hz " + Num(rate_hz) + "), got " +
              Num(link.timeout_ms));
    }
  }
  if (auto v = map.Optional("accept_only_peer_address")) link.udp.accept_only_peer_address = v->AsBool();
  if (auto v = map.Optional("receive_buffer_bytes")) {
    link.udp.receive_buffer_bytes = IntInRange(*v, 0, 1 << 30);
  }
}

void ParseLaw(const Field& f, double rate_hz, control::ThreeChannelLaw::Config& law) {
  const Map map(f, {"kp_N_per_m", "kd_Ns_per_m", "kv_Ns_per_m", "kf", "peer_position_scale", "peer_force_scale",
                    "max_force_N", "velocity_filter_hz"});
  const int dof = law.dof;
  law.kp_N_per_m = ReadGain(map, "kp_N_per_m", dof, true, "N/m");
  law.kd_Ns_per_m = ReadGain(map, "kd_Ns_per_m", dof, true, "N·s/m");
  law.kv_Ns_per_m = ReadGain(map, "kv_Ns_per_m", dof, false, "N·s/m");
  law.kf = ZeroDof(dof);
  if (auto v = map.Optional("kf")) law.kf = ReadDofVector(*v, dof, Finite);
  const auto scale = [](const Field& e) {
    const double s = Finite(e);
    if (s == 0.0) e.Fail("must be non-zero (negative mirrors the axis)");
    return s;
  };
  if (auto v = map.Optional("peer_position_scale")) law.peer_position_scale = scale(*v);
  if (auto v = map.Optional("peer_force_scale")) law.peer_force_scale = Finite(*v);
  if (auto v = map.Optional("max_force_N")) law.max_force_N = NonNegative(*v, "N");
  if (auto v = map.Optional("velocity_filter_hz")) {
    law.velocity_filter_hz = InRange(*v, 0.0, rate_hz / 2.0, "Hz (0 = off; below half of rate_hz)");
    if (law.velocity_filter_hz >= rate_hz / 2.0) {
      v->Fail("must be below half of rate_hz (" + Num(rate_hz / 2.0) + " Hz, the Nyquist frequency), got " +
              Num(law.velocity_filter_hz));
    }
  }
}

void ParseFixture(const Field& f, int dof, control::ForbiddenRegionFixture::Config& fixture) {
  using control::ForbiddenRegionFixture;
  const Map map(f, {"stiffness_N_per_m", "planes", "half_space"});
  fixture.dof = dof;
  fixture.stiffness_N_per_m = NonNegative(map.Required("stiffness_N_per_m"), "N/m");
  const auto planes = map.Optional("planes");
  const auto half_space = map.Optional("half_space");
  if (planes && half_space) half_space->Fail("give either 'planes' or 'half_space', not both");
  if (!planes && !half_space)
    f.Fail("needs either 'planes: [{normal, offset_m}, ...]' or 'half_space: {axis, offset_m}'");
  if (half_space) {
    const Map hs(*half_space, {"axis", "offset_m", "direction"});
    const int axis = IntInRange(hs.Required("axis"), 0, dof - 1);
    const double offset_m = Finite(hs.Required("offset_m"));
    int direction = 1;
    if (auto v = hs.Optional("direction")) {
      direction = v->AsInt();
      if (direction != 1 && direction != -1) v->Fail("must be +1 (forbid x > offset) or -1 (forbid x < offset)");
    }
    control::FixturePlane plane;
    plane.normal = ZeroDof(dof);
    plane.normal[axis] = direction;
    plane.offset_m = direction * offset_m;
    fixture.plane_count = 1;
    fixture.planes[0] = plane;
    return;
  }
  const std::vector<Field> items = planes->AsList();
  if (items.empty() || static_cast<int>(items.size()) > ForbiddenRegionFixture::kMaxPlanes) {
    planes->Fail("expected 1.." + std::to_string(ForbiddenRegionFixture::kMaxPlanes) + " planes, got " +
                 std::to_string(items.size()));
  }
  fixture.plane_count = static_cast<int>(items.size());
  for (std::size_t i = 0; i < items.size(); ++i) {
    const Map p(items[i], {"normal", "offset_m"});
    const Field normal_field = p.Required("normal");
    if (!normal_field.IsSequence()) normal_field.Fail("expected a list of " + std::to_string(dof) + " numbers");
    control::FixturePlane plane;
    plane.normal = ReadDofVector(normal_field, dof, Finite);
    if (!(plane.normal.norm() > 1e-9)) normal_field.Fail("the normal must not be zero");
    plane.offset_m = Finite(p.Required("offset_m"));
    fixture.planes[i] = plane;
  }
}

/// `device:`: the backend's name, and its own section `device.<backend>` read by the backend's registered reader.
/// Sections of other registered backends are rejected (they would be silently ignored).
void ParseDevice(const Field& f, Role role, int dof, device::DeviceConfig& device) {
  std::vector<std::string> allowed{"backend"};
  for (const std::string& name : device::RegisteredDevices()) allowed.push_back(name);
  const Map map(f, allowed);
  const Field backend_field = map.Required("backend");
  device.backend = backend_field.AsString();
  device.dof = dof;
  const device::DeviceBackend* backend = device::FindDevice(device.backend);
  if (backend == nullptr) backend_field.Fail(device::UnknownBackendMessage(device.backend));
  for (const std::string& name : device::RegisteredDevices()) {
    if (name == device.backend) continue;
    if (auto other = map.Optional(name)) {
      other->Fail("a section for backend '" + name + "', but backend is '" + device.backend + "'; remove it");
    }
  }
  std::optional<Field> section = map.Optional(device.backend);
  if (!section && backend->section_required) map.Required(device.backend);  // fails with the key's name
  device.section = backend->read(section ? &*section : nullptr, device::SectionContext{role, dof});
}

void ParseTelemetry(const Field& f, TelemetryConfig& telemetry) {
  const Map map(f, {"csv", "decimation", "ring_capacity"});
  if (auto v = map.Optional("csv")) telemetry.csv_path = v->AsString();
  if (auto v = map.Optional("decimation")) telemetry.decimation = IntInRange(*v, 1, 1'000'000);
  if (auto v = map.Optional("ring_capacity")) telemetry.ring_capacity = IntInRange(*v, 16, 1 << 24);
}

/// The start-up stability check (docs/stability.md, "In the processes"). Absent keys keep StabilityConfig's defaults.
void ParseStability(const Field& f, int dof, StabilityConfig& stability) {
  const Map map(f, {"check", "peer_delay_samples", "unilateral", "human_bounds", "human_grid_steps", "peer", "device"});
  if (auto v = map.Optional("check")) stability.check = v->AsBool();
  if (auto v = map.Optional("peer_delay_samples")) stability.peer_delay_samples = IntInRange(*v, 0, 1);
  if (auto v = map.Optional("unilateral")) stability.unilateral = v->AsBool();
  if (auto v = map.Optional("human_bounds")) stability.human_bounds = v->AsString();
  // 8 steps = 8^3 operators per force level: about 8x the default's start-up time.
  if (auto v = map.Optional("human_grid_steps")) stability.human_grid_steps = IntInRange(*v, 1, 8);
  if (auto v = map.Optional("peer")) {
    const Map peer(*v, {"mass_kg", "damping_Ns_per_m", "kp_N_per_m", "kd_Ns_per_m", "kv_Ns_per_m", "kf",
                        "fixture_stiffness_N_per_m"});
    StabilityConfig::Peer& p = stability.peer;
    if (auto m = peer.Optional("mass_kg")) p.mass_kg = Positive(*m, "kg");
    if (auto b = peer.Optional("damping_Ns_per_m")) p.damping_Ns_per_m = NonNegative(*b, "N·s/m");
    if (peer.Has("kp_N_per_m")) p.kp_N_per_m = ReadGain(peer, "kp_N_per_m", dof, true, "N/m");
    if (peer.Has("kd_Ns_per_m")) p.kd_Ns_per_m = ReadGain(peer, "kd_Ns_per_m", dof, true, "N·s/m");
    if (peer.Has("kv_Ns_per_m")) p.kv_Ns_per_m = ReadGain(peer, "kv_Ns_per_m", dof, true, "N·s/m");
    if (auto k = peer.Optional("kf")) p.kf = ReadDofVector(*k, dof, Finite);
    if (auto k = peer.Optional("fixture_stiffness_N_per_m")) p.fixture_stiffness_N_per_m = NonNegative(*k, "N/m");
  }
  if (auto v = map.Optional("device")) {
    const Map device(*v, {"mass_kg", "damping_Ns_per_m"});
    if (auto m = device.Optional("mass_kg")) stability.device.mass_kg = Positive(*m, "kg");
    if (auto b = device.Optional("damping_Ns_per_m")) stability.device.damping_Ns_per_m = NonNegative(*b, "N·s/m");
  }
}

ProcessConfig Parse(const YAML::Node& root_node, const std::string& name) {
  const Field root(root_node, "", &name);
  if (root_node.IsNull() || !root_node.IsDefined()) {
    throw Error(name + ": the config is empty; it needs at least role, dof, rate_hz, link, law and device");
  }
  const Map map(root, {"role", "dof", "rate_hz", "duration_s", "realtime", "link", "law", "fixture", "device",
                       "telemetry", "stability", "dds"});
  ProcessConfig config;
  config.source_path = name;
  config.role = ParseRole(map.Required("role"));
  config.dof = IntInRange(map.Required("dof"), 1, kMaxDof);
  config.loop.rate_hz = InRange(map.Required("rate_hz"), kMinRateHz, kMaxRateHz, "Hz");
  if (auto v = map.Optional("duration_s")) config.loop.duration_s = NonNegative(*v, "s (0 = until stopped)");
  if (auto v = map.Optional("realtime")) ParseRealtime(*v, config.loop);

  ParseLink(map.Required("link"), config.role, config.loop.rate_hz, config.dof, config.link);

  config.law.role = config.role;
  config.law.dof = config.dof;
  ParseLaw(map.Required("law"), config.loop.rate_hz, config.law);
  config.law.fixture.dof = config.dof;
  if (auto v = map.Optional("fixture")) ParseFixture(*v, config.dof, config.law.fixture);

  ParseDevice(map.Required("device"), config.role, config.dof, config.device);
  if (auto v = map.Optional("telemetry")) ParseTelemetry(*v, config.telemetry);
  if (auto v = map.Optional("stability")) ParseStability(*v, config.dof, config.stability);
  if (auto v = map.Optional("dds")) detail::ParseDds(*v, config.loop.rate_hz, config.dds);  // docs/dds.md
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
