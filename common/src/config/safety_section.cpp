// The `engagement:` and `safety:` sections (teleop/config/engagement_config.hpp, docs/configuration.md).

#include <string>

#include "sections.hpp"

namespace teleop::config::sections {

Reaction DefaultReaction(Role role) noexcept { return role == Role::kSlave ? Reaction::kHold : Reaction::kFade; }

void ParseEngagement(const Field& f, EngagementConfig& e) {
  const Map map(
      f, {"align_speed_m_per_s", "align_min_time_ms", "align_tolerance_m", "max_force_rate_N_per_s", "max_rtt_ms"});
  if (auto v = map.Optional("align_speed_m_per_s")) e.align_speed_m_per_s = InRange(*v, 1e-6, 10.0, "m/s");
  if (auto v = map.Optional("align_min_time_ms")) e.align_min_time_ms = InRange(*v, 0.0, 60'000.0, "ms");
  if (auto v = map.Optional("align_tolerance_m")) e.align_tolerance_m = InRange(*v, 1e-9, 0.01, "m");
  if (auto v = map.Optional("max_force_rate_N_per_s")) e.max_force_rate_N_per_s = InRange(*v, 1e-3, 1e6, "N/s");
  if (auto v = map.Optional("max_rtt_ms")) e.max_rtt_ms = InRange(*v, 0.0, 60'000.0, "ms (0 = off)");
}

void ParseSafety(const Field& f, Role role, SafetyConfig& s) {
  const Map map(f, {"reaction", "hold_max_force_N", "decelerate_m_per_s2", "fade_time_ms", "damping_Ns_per_m",
                    "fault_record_cycles", "fault_record_dir", "max_fault_records", "max_abs_position_m",
                    "max_abs_force_sensor_N", "max_speed_m_per_s", "encoder_slack_m"});
  if (auto v = map.Optional("reaction")) {
    const std::string text = v->AsString();
    const bool slave = role == Role::kSlave;
    if (text == "hold" && slave) {
      s.reaction = Reaction::kHold;
    } else if (text == "decelerate" && slave) {
      s.reaction = Reaction::kDecelerate;
    } else if (text == "fade" && !slave) {
      s.reaction = Reaction::kFade;
    } else if (text == "damping" && !slave) {
      s.reaction = Reaction::kDamping;
    } else if (text == "zero_force") {
      s.reaction = Reaction::kZeroForce;
    } else if (text == "brake") {
      s.reaction = Reaction::kBrake;
    } else {
      v->Fail(slave ? "the slave's reaction must be 'hold', 'decelerate', 'zero_force' or 'brake', got '" + text + "'"
                    : "the master's reaction must be 'fade', 'damping', 'zero_force' or 'brake', got '" + text + "'");
    }
  }
  if (auto v = map.Optional("hold_max_force_N")) s.hold_max_force_N = InRange(*v, 0.0, 1e6, "N");
  if (auto v = map.Optional("decelerate_m_per_s2")) s.decelerate_m_per_s2 = InRange(*v, 1e-6, 1e4, "m/s^2");
  if (auto v = map.Optional("fade_time_ms")) s.fade_time_ms = InRange(*v, 0.0, 60'000.0, "ms");
  if (auto v = map.Optional("damping_Ns_per_m")) s.damping_Ns_per_m = InRange(*v, 0.0, 1e6, "N s/m");
  if (auto v = map.Optional("fault_record_cycles")) s.fault_record_cycles = IntInRange(*v, 1, 1'000'000);
  if (auto v = map.Optional("fault_record_dir")) s.fault_record_dir = v->AsString();
  if (auto v = map.Optional("max_fault_records")) s.max_fault_records = IntInRange(*v, 0, 100'000);
  if (auto v = map.Optional("max_abs_position_m")) s.max_abs_position_m = InRange(*v, 0.0, 1e3, "m (0 = off)");
  if (auto v = map.Optional("max_abs_force_sensor_N")) {
    s.max_abs_force_sensor_N = InRange(*v, 0.0, 1e6, "N (0 = off)");
  }
  if (auto v = map.Optional("max_speed_m_per_s")) s.max_speed_m_per_s = InRange(*v, 0.0, 1e3, "m/s (0 = off)");
  if (auto v = map.Optional("encoder_slack_m")) s.encoder_slack_m = InRange(*v, 0.0, 1.0, "m");
}

}  // namespace teleop::config::sections
