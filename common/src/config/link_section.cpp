// The `link:` section (docs/configuration.md, docs/can.md).

#include <arpa/inet.h>

#include <algorithm>
#include <string>
#include <vector>

#include "sections.hpp"
#include "teleop/config/delay_recheck_keys.hpp"

namespace teleop::config::sections {

namespace {

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
  const Map map(f, {"interface", "bus", "fd", "bit_rate_switch", "nominal_bitrate_bit_per_s", "data_bitrate_bit_per_s",
                    "extended_id", "master_to_slave_base_id", "slave_to_master_base_id", "max_bus_load",
                    "connect_timeout_ms", "log_path"});
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
    const std::string text = v->AsString();
    if (text.rfind("unix:", 0) == 0) {  // a Unix-domain socket (docs/security.md, "What CAN trusts")
      if (text.size() <= 5 || text.size() > 5 + 107 || text[5] != '/') {
        v->Fail(
            "unix:PATH needs an absolute path of at most 107 characters (e.g. unix:/run/teleop/canbus.sock), "
            "got '" +
            text + "'");
      }
      can.emulated_bus_host = text;
      can.emulated_bus_port = 0;
    } else {
      const Endpoint bus = ParseEndpoint(*v);
      can.emulated_bus_host = bus.address;
      can.emulated_bus_port = bus.port;
    }
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
  if (auto v = map.Optional("log_path")) can.log_path = v->AsString();  // opened (and refused) at start-up
}

// The `link.delay_recheck` section (docs/stability.md, "Run-time re-check"), read through its key table.
void ParseDelayRecheck(const Field& f, link::LinkConfig::DelayRecheck& r) {
  namespace k = delay_recheck_keys;
  std::vector<std::string> leaves;
  leaves.reserve(k::kAll.size());
  for (const KeySpec* spec : k::kAll) leaves.push_back(LeafOf(*spec));
  const Map map(f, leaves);
  r.enabled = ReadBool(map, k::kEnabled);
  r.window_s = ReadNumber(map, k::kWindow);
  r.percentile = ReadNumber(map, k::kPercentile);
  r.trigger_ratio = ReadNumber(map, k::kTriggerRatio);
  r.recover_ratio = ReadNumber(map, k::kRecoverRatio);
  r.recover_hold_s = ReadNumber(map, k::kRecoverHold);
  r.margin = ReadNumber(map, k::kMargin);
  r.max_force_rate_N_per_s = ReadNumber(map, k::kMaxForceRate);
  r.max_penetration_m = ReadNumber(map, k::kMaxPenetration);
  r.on_unstable = ReadChoiceAs<link::LinkConfig::DelayRecheck::OnUnstable>(map, k::kOnUnstable);
  if (r.recover_ratio > r.trigger_ratio) {
    f.Fail("recover_ratio (" + Num(r.recover_ratio) + ") must be at most trigger_ratio (" + Num(r.trigger_ratio) +
           "): the band between them is the hysteresis");
  }
}

}  // namespace

void ParseLink(const Field& f, Role role, double rate_hz, int dof, link::LinkConfig& link) {
  const Map map(f, {"transport", "bind", "peer", "timeout_ms", "expected_delay_ms", "accept_only_peer_address",
                    "receive_buffer_bytes", "busy_poll_us", "can", "emulate", "security", "delay_recheck"});
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
    for (const char* udp_only : {"bind", "peer", "accept_only_peer_address", "receive_buffer_bytes", "busy_poll_us"}) {
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
  if (auto v = map.Optional("expected_delay_ms")) link.expected_delay_ms = InRange(*v, 0.0, 1000.0, "ms");
  if (auto v = map.Optional("accept_only_peer_address")) link.udp.accept_only_peer_address = v->AsBool();
  ParseSecurity(map, link.transport, dof, link.security);
  if (auto v = map.Optional("receive_buffer_bytes")) {
    link.udp.receive_buffer_bytes = IntInRange(*v, 0, 1 << 30);
  }
  if (auto v = map.Optional("busy_poll_us")) link.udp.busy_poll_us = IntInRange(*v, 0, 100'000);
  if (auto v = map.Optional("emulate")) ParseLinkEmulate(*v, rate_hz, link.emulate);
  if (auto v = map.Optional("delay_recheck")) ParseDelayRecheck(*v, link.delay_recheck);
}

}  // namespace teleop::config::sections
