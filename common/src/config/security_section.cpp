// The `link.security` section (docs/configuration.md, docs/security.md).

#include <string>

#include "sections.hpp"
#include "teleop/transport/secure_key_file.hpp"

namespace teleop::config::sections {

namespace {

constexpr const char* kHowTo =
    "make a key with `teleop-keygen teleop.key` (beside this config; copy the same file to the other machine) and "
    "write `security: {mode: psk, key_file: teleop.key}`, or, on a bench, opt out explicitly with "
    "`security: {mode: insecure}` (docs/security.md)";

}  // namespace

void ParseSecurity(const Map& link, const std::string& transport, int dof, transport::LinkSecurityConfig& security) {
  const std::optional<Field> section = link.Optional("security");
  if (!section) {
    link.self().Fail("no 'security' section: the link must say how it is protected; " + std::string(kHowTo));
  }
  const Map map(*section,
                {"mode", "key_file", "max_speed_m_per_s", "max_force_N", "position_slack_m", "max_datagrams_per_s",
                 "datagram_burst", "max_handshakes_per_s", "handshake_burst", "handshake_retry_ms"});
  const Field mode = map.Required("mode");
  const std::string text = mode.AsString();
  if (text == "insecure") {
    security.mode = transport::LinkSecurityMode::kInsecure;
    for (const char* key : {"key_file", "max_speed_m_per_s", "max_force_N", "position_slack_m", "max_datagrams_per_s",
                            "datagram_burst", "max_handshakes_per_s", "handshake_burst", "handshake_retry_ms"}) {
      if (auto v = map.Optional(key)) v->Fail("only for mode psk (an insecure link checks nothing of this)");
    }
    return;
  }
  if (text != "psk") mode.Fail("must be psk or insecure, got '" + text + "'");
  if (transport != "udp") {
    mode.Fail("psk is not available on transport " + transport +
              ": a 16-byte authentication tag does not fit the CAN frames (docs/security.md, \"CAN\"); on a closed "
              "bus write mode: insecure, or use transport udp");
  }
  security.mode = transport::LinkSecurityMode::kPsk;
  const Field key = map.Required("key_file");
  const std::string path = key.AsString();
  if (path.empty()) key.Fail("must name the pre-shared key file; " + std::string(kHowTo));
  // Beside the config, unless it names a systemd credential (credential:NAME, resolved when the link opens).
  const bool credential = path.rfind(transport::kCredentialPrefix, 0) == 0;
  security.key_file = credential ? path : BesideConfigFile(key.file(), path);
  transport::SecureSessionConfig& s = security.session;
  s.dof = dof;
  if (auto v = map.Optional("max_speed_m_per_s")) s.max_speed_m_per_s = Positive(*v, "m/s");
  if (auto v = map.Optional("max_force_N")) s.max_force_N = Positive(*v, "N");
  if (auto v = map.Optional("position_slack_m")) s.position_slack_m = InRange(*v, 0.0, 1.0, "m");
  if (auto v = map.Optional("max_datagrams_per_s")) s.max_datagrams_per_s = InRange(*v, 1.0, 1e6, "datagrams/s");
  if (auto v = map.Optional("datagram_burst")) s.datagram_burst = InRange(*v, 1.0, 1e6, "datagrams");
  if (auto v = map.Optional("max_handshakes_per_s")) s.max_handshakes_per_s = InRange(*v, 0.1, 1000.0, "1/s");
  if (auto v = map.Optional("handshake_burst")) s.handshake_burst = InRange(*v, 1.0, 1000.0, "handshakes");
  if (auto v = map.Optional("handshake_retry_ms")) security.handshake_retry_ms = InRange(*v, 1.0, 60'000.0, "ms");
}

}  // namespace teleop::config::sections
