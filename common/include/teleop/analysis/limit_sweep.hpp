#pragma once

#include <cstdint>
#include <iosfwd>
#include <span>
#include <string>
#include <vector>

#include "teleop/analysis/stability_limit.hpp"

namespace teleop::analysis {

/// The parameter a curve runs over (the paper's Figs. 7, 10, 11, 14: rate; 8, 9, 12, 13: K_p and K_d, set on both
/// sides as in the symmetric law of §4.3, or only on the slave when `unilateral`, where the master gains are 0).
/// kLinkDelayMs: a link's one-way delay (ms) added to both directions on top of the system's own (AddLinkDelay).
enum class SweepVariable : std::uint8_t { kRateHz = 0, kKp = 1, kKd = 2, kLinkDelayMs = 3 };

const char* ToString(SweepVariable variable) noexcept;
/// "rate", "kp", "kd" or "delay"; throws teleop::Error otherwise.
SweepVariable ParseSweepVariable(const std::string& name);

struct SweepPoint {
  double value = 0.0;  ///< Hz, N/m, N·s/m or ms according to the variable.
  StabilityLimit limit{};
};

/// One stiffness limit per value of `variable`, the rest of `system` fixed.
std::vector<SweepPoint> SweepLimit(const SampledTeleoperator& system, FixtureSide side,
                                   std::span<const HumanModel> humans, SweepVariable variable,
                                   std::span<const double> values, const LimitOptions& options = {});

/// CSV with a header: value, max_stable_stiffness_N_per_m, passivity_bound_N_per_m, worst_damping_ratio and the
/// limiting operator (mass_kg, damping_Ns_per_m, stiffness_N_per_m, force_N). The first column is named after the
/// variable with its unit (rate_hz, kp_N_per_m, kd_Ns_per_m, link_delay_ms).
void WriteSweepCsv(std::ostream& out, SweepVariable variable, std::span<const SweepPoint> points);

}  // namespace teleop::analysis
