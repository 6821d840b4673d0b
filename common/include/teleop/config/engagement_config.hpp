#pragma once

// The `engagement:` and `safety:` sections of a process config (docs/configuration.md; read by
// common/src/config/safety_section.cpp). Header-only plain data of the config layer; the node, which acts on them,
// names them as its own (teleop/node/engagement_config.hpp).

#include <cstdint>
#include <string>

namespace teleop::config {

/// How coupling starts and restarts (the node acts on it: teleop/node/engagement.hpp).
struct EngagementConfig {
  /// Aligning: the coupling reference (what the law is told the peer's position is) starts at the local position
  /// and moves to the peer's at most this fast (m/s, local frame). Bounds the reference step to speed × period.
  double align_speed_m_per_s = 0.05;
  /// Aligning lasts at least this long; K_f's peer force ramps in linearly over it (ms).
  double align_min_time_ms = 50.0;
  /// Reference within this of the peer's position (every axis) ends aligning (m). The small default means "caught
  /// up": the step at the switch to engaged is then the peer's own motion in one cycle.
  double align_tolerance_m = 1e-6;
  /// While aligning, the coupling part of the command (command minus the fixture's share) changes by at most this
  /// rate (N/s per axis). The fixture is never rate limited.
  double max_force_rate_N_per_s = 100.0;
  /// Latency gate: a measured round trip above this disengages; the gate reopens below 80 % of it (ms). 0: off.
  double max_rtt_ms = 100.0;
};

/// What a process does while it is not coupled (peer lost, peer fault or shutdown, new session, latency gate,
/// before the first sample): latched from the moment coupling stops until the pair has re-aligned.
enum class Reaction : std::uint8_t {
  kHold,        ///< Slave: PD (the law's K_p, K_d) to the position latched at the loss, force ≤ hold_max_force_N;
                ///< K_v and the fixture stay on.
  kZeroForce,   ///< Either: zero force command (the device coasts).
  kBrake,       ///< Either: Device::SetSafe every cycle on a device whose capabilities have a brake.
  kDecelerate,  ///< Slave: a reference decelerating from the velocity at the loss at decelerate_m_per_s2, then
                ///< hold at its stop; same PD and force bound as kHold.
  kFade,        ///< Master: the coupling force at the loss fades linearly to zero over fade_time_ms; K_v and the
                ///< fixture stay on.
  kDamping,     ///< Master: pure damping, -damping_Ns_per_m · velocity (no fixture).
};

inline const char* ToString(Reaction reaction) noexcept {
  switch (reaction) {
    case Reaction::kHold:
      return "hold";
    case Reaction::kZeroForce:
      return "zero_force";
    case Reaction::kBrake:
      return "brake";
    case Reaction::kDecelerate:
      return "decelerate";
    case Reaction::kFade:
      return "fade";
    case Reaction::kDamping:
      return "damping";
  }
  return "?";
}

/// Safe states, fault records and the node's own plausibility checks of the device's readings.
struct SafetyConfig {
  Reaction reaction = Reaction::kHold;  ///< The config reader sets the role's default: slave hold, master fade.
  double hold_max_force_N = 5.0;        ///< kHold/kDecelerate: bound of the PD part, per axis (N).
  double decelerate_m_per_s2 = 1.0;     ///< kDecelerate: deceleration of the reference (m/s²).
  double fade_time_ms = 200.0;          ///< kFade.
  double damping_Ns_per_m = 2.0;        ///< kDamping.

  int fault_record_cycles = 500;  ///< Cycles kept for a fault record (the last N before the fault).
  std::string fault_record_dir;   ///< Empty: the telemetry CSV's directory when set, else the working directory.
  int max_fault_records = 20;     ///< Files written per run at most; later faults are counted, not written.

  // Plausibility of the device's readings (a failure is a device fault: safe state + fault record). 0 = off.
  double max_abs_position_m = 1.0;      ///< |position| on any axis beyond this: out of range.
  double max_abs_force_sensor_N = 0.0;  ///< |force sensor| beyond this (when the device measures force).
  double max_speed_m_per_s = 10.0;      ///< Encoder jump: |Δposition| > max_speed · period + encoder_slack_m.
  double encoder_slack_m = 1e-3;
};

}  // namespace teleop::config
