#include "teleop/link/link_config.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "teleop/error.hpp"
#include "teleop/transport/can_link.hpp"
#include "teleop/transport/impaired_link.hpp"

namespace teleop::link {
namespace {

using transport::CanLinkConfig;
using transport::CanMedium;
using transport::ImpairedLink;
using transport::ImpairmentConfig;
using transport::Link;
using transport::LinkSecurityMode;
using transport::UdpLink;
using transport::UdpLinkConfig;

using Factory = std::unique_ptr<Link> (*)(const LinkConfig&, proto::SenderRole);

std::unique_ptr<Link> MakeUdp(const LinkConfig& config, proto::SenderRole local_role) {
  if (config.udp.peer_port == 0) {
    throw Error("link 'udp': peer port must be 1..65535 (where the other process listens), got 0");
  }
  UdpLinkConfig udp = config.udp;
  udp.expected_peer = proto::PeerOf(local_role);
  udp.security = config.security;
  udp.peer_silence_ms = config.timeout_ms;
  return std::make_unique<UdpLink>(udp);
}

std::unique_ptr<Link> MakeCan(const LinkConfig& config, proto::SenderRole local_role, CanMedium medium) {
  if (config.security.mode != LinkSecurityMode::kInsecure) {
    throw Error(std::string("link '") + (medium == CanMedium::kSocketCan ? "can" : "emulated-can") +
                "': link.security.mode " + transport::ToString(config.security.mode) +
                " is not available on CAN (a 16-byte tag does not fit the frames; docs/security.md, \"CAN\"); on a "
                "closed bus set link.security.mode: insecure, or use transport udp");
  }
  CanLinkConfig can = config.can;
  can.medium = medium;
  return transport::MakeCanLink(can, local_role, config.rate_hz);
}

std::unique_ptr<Link> MakeSocketCan(const LinkConfig& config, proto::SenderRole local_role) {
  return MakeCan(config, local_role, CanMedium::kSocketCan);
}

std::unique_ptr<Link> MakeEmulatedCan(const LinkConfig& config, proto::SenderRole local_role) {
  return MakeCan(config, local_role, CanMedium::kEmulatedBus);
}

struct Backend {
  const char* name;
  Factory make;
};

// One entry per transport.
constexpr std::array<Backend, 3> kBackends = {
    {{"udp", &MakeUdp}, {"can", &MakeSocketCan}, {"emulated-can", &MakeEmulatedCan}}};

// `link.emulate`: the opened link behind the emulated network, sized for the loop rate.
std::unique_ptr<Link> Emulated(const LinkConfig& config, proto::SenderRole local_role, std::unique_ptr<Link> link) {
  if (!config.emulate.enabled) return link;
  ImpairmentConfig impairments = config.emulate.impairments;
  // Slots for everything in flight at the loop rate (one sample per cycle), duplicates included, plus margin.
  double longest_delay_s = impairments.delay_s;  // the delay line must hold the longest step's flight too
  for (const transport::DelayStep& step : impairments.delay_steps)
    longest_delay_s = std::max(longest_delay_s, step.delay_s);
  const double in_flight_s =
      longest_delay_s + impairments.jitter_s + (impairments.bandwidth_bit_per_s > 0 ? impairments.queue_limit_s : 0.0);
  const double slots = std::ceil(std::max(config.rate_hz, 1.0) * in_flight_s * 2.0) + 64.0;
  impairments.capacity = static_cast<int>(std::min(slots, 65536.0));
  const double periods = (impairments.delay_s + impairments.jitter_s) * config.rate_hz;
  if (periods > 1.0) {
    spdlog::warn(
        "link.emulate delays what this process receives by up to {:.1f} ms ({:.0f} loop periods); the start-up "
        "stability check models the peer's data one period old, so its verdict does not cover this delay",
        (impairments.delay_s + impairments.jitter_s) * 1e3, periods);
  }
  return std::make_unique<ImpairedLink>(std::move(link), impairments, config.emulate.seed, proto::PeerOf(local_role));
}

}  // namespace

std::unique_ptr<Link> MakeLink(const LinkConfig& config, proto::SenderRole local_role) {
  if (!std::isfinite(config.timeout_ms) || config.timeout_ms <= 0.0) {
    throw Error("link: timeout_ms must be a finite number > 0, got " + std::to_string(config.timeout_ms));
  }
  if (local_role != proto::SenderRole::kMaster && local_role != proto::SenderRole::kSlave) {
    throw Error("link: the local role must be master or slave");
  }
  std::string known;
  for (const Backend& backend : kBackends) {
    if (config.transport == backend.name) return Emulated(config, local_role, backend.make(config, local_role));
    known += (known.empty() ? "" : ", ") + std::string("'") + backend.name + "'";
  }
  throw Error("link: unknown transport '" + config.transport + "'; known transports: " + known);
}

}  // namespace teleop::link
