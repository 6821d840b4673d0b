#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "teleop/transport/can_link_config.hpp"
#include "teleop/transport/impairment_model.hpp"
#include "teleop/transport/link.hpp"
#include "teleop/transport/link_security.hpp"
#include "teleop/transport/udp_link.hpp"
#include "teleop/types.hpp"

// library teleop::link (common/src/link/link_config.cpp): the one place that knows every transport, above them in
// its own namespace.
namespace teleop::link {

/// Per-process link selection. `transport` is "udp", "can" (SocketCAN) or "emulated-can" (the teleop-canbus daemon,
/// for hosts without CAN).
struct LinkConfig {
  std::string transport = "udp";
  transport::UdpLinkConfig udp{};
  transport::CanLinkConfig can{};  ///< Used by "can" and "emulated-can"; its dof is the process's dof.
  double rate_hz = 1000.0;         ///< The loop rate, for the CAN bus-load budget (set from the process config).
  double timeout_ms = 50.0;        ///< Watchdog: no accepted sample for this long → peer lost → safe state.
  /// `link.expected_delay_ms`: the link's one-way delay the start-up stability check assumes on top of the pair's
  /// own one sample (docs/stability.md, "Delay"). Absent: the emulated delay (+ jitter) when emulate is on, else 0.
  std::optional<double> expected_delay_ms;
  /// `link.emulate` (docs/link-emulation.md): when enabled, the opened link is wrapped in an ImpairedLink that
  /// impairs what this process receives.
  struct Emulation {
    bool enabled = false;
    transport::ImpairmentConfig impairments{};
    std::uint64_t seed = 1;
  } emulate{};
  /// `link.delay_recheck` (docs/stability.md, "Run-time re-check"; keys: teleop/config/delay_recheck_keys.hpp, whose
  /// defaults are these initialisers): when the measured data age's high percentile exceeds what the start-up check
  /// assumed, the check runs again off the real-time thread with the measured delay and the fixture ramps to the new
  /// limit; back when the link recovers.
  struct DelayRecheck {
    enum class OnUnstable : std::uint8_t { kEvent = 0, kDecouple = 1, kPassivity = 2 };
    bool enabled = false;
    double window_s = 1.0;                 ///< The percentile is over this much of the newest data ages.
    double percentile = 0.99;              ///< 0.5..1.
    double trigger_ratio = 1.25;           ///< Slower: the percentile above the assumed age × this.
    double recover_ratio = 1.1;            ///< Recovered: at or below the assumed age × this (≤ trigger_ratio) ..
    double recover_hold_s = 2.0;           ///< .. for this long.
    double margin = 0.9;                   ///< The new fixture stiffness is this × the limit at the measured delay.
    double max_force_rate_N_per_s = 20.0;  ///< The ramp's force rate at max_penetration_m.
    double max_penetration_m = 0.01;       ///< The penetration the ramp's force rate is bounded at.
    OnUnstable on_unstable =
        OnUnstable::kEvent;  ///< No fixture is stable at the measured delay: event, decouple, passivity.
  } delay_recheck{};
  /// `link.security` (docs/security.md): psk on UDP; CAN accepts only insecure (no room for a tag per frame).
  transport::LinkSecurityConfig security{};
};

/// The wire's name for a process of role `role` (the one mapping from teleop::Role to proto::SenderRole).
constexpr proto::SenderRole ToSender(Role role) noexcept {
  return role == Role::kMaster ? proto::SenderRole::kMaster : proto::SenderRole::kSlave;
}

/// Opens the configured link for a process of role `local_role`, wrapped in the emulated network when
/// `emulate.enabled`. Throws teleop::Error on failure.
std::unique_ptr<transport::Link> MakeLink(const LinkConfig& config, proto::SenderRole local_role);

}  // namespace teleop::link
