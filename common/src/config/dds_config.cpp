#include "dds_config.hpp"

#include <cmath>
#include <sstream>
#include <string>

#include "teleop/dds/topic_names.hpp"

namespace teleop::config::detail {

namespace {

/// DDS domain ids map to UDP ports 7400 + 250 * id (DDSI-RTPS 9.6.1.1): 232 is the highest that fits.
constexpr int kMaxDomainId = 232;

std::string Num(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace

void ParseDds(const Field& field, double loop_rate_hz, dds::BridgeConfig& dds) {
  const Map map(field, {"enabled", "domain_id", "pair", "state_rate_hz", "ring_capacity"});
  if (auto v = map.Optional("enabled")) dds.enabled = v->AsBool();
  if (auto v = map.Optional("domain_id")) {
    dds.domain_id = v->AsInt();
    if (dds.domain_id < 0 || dds.domain_id > kMaxDomainId) {
      v->Fail("must be an integer in 0.." + std::to_string(kMaxDomainId) + " (the DDS domain, as ROS_DOMAIN_ID), got " +
              std::to_string(dds.domain_id));
    }
  }
  if (auto v = map.Optional("pair")) {
    dds.pair = v->AsString();
    if (!dds::IsValidNameToken(dds.pair)) {
      v->Fail("'" + dds.pair + "' is not a valid topic name part: 1.." + std::to_string(dds::kMaxPairNameLength) +
              " letters, digits and single underscores, starting with a letter (it becomes rt/teleop/<pair>/...)");
    }
  }
  if (auto v = map.Optional("state_rate_hz")) {
    const double rate = v->AsDouble();
    if (!std::isfinite(rate) || rate < 0.1 || rate > loop_rate_hz) {
      v->Fail("must be in 0.1.." + Num(loop_rate_hz) + " Hz (at most rate_hz), got " + Num(rate));
    }
    dds.state_rate_hz = rate;
  } else if (dds.state_rate_hz > loop_rate_hz) {
    dds.state_rate_hz = loop_rate_hz;
  }
  if (auto v = map.Optional("ring_capacity")) {
    const int capacity = v->AsInt();
    if (capacity < 16 || capacity > 65536) {
      v->Fail("must be an integer in 16..65536 (state records), got " + std::to_string(capacity));
    }
    dds.ring_capacity = capacity;
  }
}

}  // namespace teleop::config::detail
