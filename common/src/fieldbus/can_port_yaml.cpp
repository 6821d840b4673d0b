#include "teleop/fieldbus/can_port_yaml.hpp"

#include <optional>
#include <string>

#include "teleop/config/yaml_reader.hpp"

namespace teleop::fieldbus {

namespace {

/// "HOST:PORT" with a port 1..65535, or fails at `f`.
void ReadBus(const config::Field& f, CanPortConfig& can) {
  const std::string text = f.AsString();
  const std::size_t colon = text.rfind(':');
  const std::string port = colon == std::string::npos ? "" : text.substr(colon + 1);
  if (colon == std::string::npos || colon == 0 || port.empty() || port.size() > 5 ||
      port.find_first_not_of("0123456789") != std::string::npos || std::stoi(port) < 1 || std::stoi(port) > 65535) {
    f.Fail(
        "must be HOST:PORT, the teleop-canbus daemon's address with a port 1..65535 like \"127.0.0.1:47300\", got '" +
        text + "'");
  }
  can.emulated_bus_host = text.substr(0, colon);
  can.emulated_bus_port = static_cast<std::uint16_t>(std::stoi(port));
}

}  // namespace

const std::array<CanPortKey, 4> kCanPortKeys{{
    {"medium", "socketcan (default) or emulated (the teleop-canbus daemon)"},
    {"interface", "SocketCAN interface (can0, vcan0, ...); required for socketcan"},
    {"bus", "teleop-canbus address IPv4:PORT (emulated only); default 127.0.0.1:47300"},
    {"connect_timeout_ms", "how long to wait for teleop-canbus (ms), > 0; default 1000"},
}};

void ReadCanPortSection(const config::Field& section, CanPortConfig& can, CanMediumKey medium) {
  const config::Map map(section, {"medium", "interface", "bus", "connect_timeout_ms"});
  const std::optional<config::Field> medium_field =
      medium == CanMediumKey::kRequired ? std::optional<config::Field>(map.Required("medium")) : map.Optional("medium");
  if (medium_field) {
    const std::string text = medium_field->AsString();
    if (text == "socketcan") {
      can.medium = transport::CanMedium::kSocketCan;
    } else if (text == "emulated") {
      can.medium = transport::CanMedium::kEmulatedBus;
    } else {
      medium_field->Fail(
          "must be socketcan or emulated (socketcan: a SocketCAN interface; emulated: the teleop-canbus daemon), got "
          "'" +
          text + "'");
    }
  }
  const bool emulated = can.medium == transport::CanMedium::kEmulatedBus;
  if (auto v = map.Optional("interface")) {
    if (emulated) v->Fail("only for medium socketcan");
    can.interface_name = v->AsString();
    if (can.interface_name.empty() || can.interface_name.size() > 15) {
      v->Fail("must be a network interface name of 1..15 characters (e.g. can0, vcan0), got '" + can.interface_name +
              "'");
    }
  } else if (!emulated) {
    map.Required("interface");
  }
  if (auto v = map.Optional("bus")) {
    if (!emulated) v->Fail("only for medium emulated (the teleop-canbus daemon's address)");
    ReadBus(*v, can);
  }
  if (auto v = map.Optional("connect_timeout_ms")) can.connect_timeout_ms = config::Positive(*v, "ms");
}

}  // namespace teleop::fieldbus
