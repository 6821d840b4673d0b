#include "teleop/analysis/limit_sweep.hpp"

#include <ostream>

#include "teleop/error.hpp"

namespace teleop::analysis {

const char* ToString(SweepVariable variable) noexcept {
  switch (variable) {
    case SweepVariable::kRateHz:
      return "rate";
    case SweepVariable::kKp:
      return "kp";
    case SweepVariable::kKd:
      return "kd";
    case SweepVariable::kLinkDelayMs:
      return "delay";
  }
  return "?";
}

SweepVariable ParseSweepVariable(const std::string& name) {
  if (name == "rate") return SweepVariable::kRateHz;
  if (name == "kp") return SweepVariable::kKp;
  if (name == "kd") return SweepVariable::kKd;
  if (name == "delay") return SweepVariable::kLinkDelayMs;
  throw Error("sweep variable '" + name + "' is unknown; use rate, kp, kd or delay");
}

std::vector<SweepPoint> SweepLimit(const SampledTeleoperator& system, FixtureSide side,
                                   std::span<const HumanModel> humans, SweepVariable variable,
                                   std::span<const double> values, const LimitOptions& options) {
  if (values.empty()) throw Error("sweep: no values to sweep over");
  std::vector<SweepPoint> points;
  points.reserve(values.size());
  for (double value : values) {
    SampledTeleoperator point = system;
    LawGains& g = point.gains;
    switch (variable) {
      case SweepVariable::kRateHz:
        point.rate_hz = value;
        break;
      case SweepVariable::kKp:
        g.kps_N_per_m = value;
        if (!system.unilateral) g.kpm_N_per_m = value;
        break;
      case SweepVariable::kKd:
        g.kds_Ns_per_m = value;
        if (!system.unilateral) g.kdm_Ns_per_m = value;
        break;
      case SweepVariable::kLinkDelayMs:
        AddLinkDelay(point, value * 1e-3);
        break;
    }
    points.push_back(SweepPoint{value, FindMaxStableStiffness(point, side, humans, options)});
  }
  return points;
}

void WriteSweepCsv(std::ostream& out, SweepVariable variable, std::span<const SweepPoint> points) {
  const char* first = variable == SweepVariable::kRateHz ? "rate_hz"
                      : variable == SweepVariable::kKp   ? "kp_N_per_m"
                      : variable == SweepVariable::kKd   ? "kd_Ns_per_m"
                                                         : "link_delay_ms";
  out << first
      << ",max_stable_stiffness_N_per_m,passivity_bound_N_per_m,worst_damping_ratio,"
         "limiting_mass_kg,limiting_damping_Ns_per_m,limiting_stiffness_N_per_m,limiting_force_N\n";
  const auto precision = out.precision(10);
  for (const SweepPoint& p : points) {
    const StabilityLimit& l = p.limit;
    out << p.value << ',' << l.max_stable_stiffness_N_per_m << ',' << l.passivity_bound_N_per_m << ','
        << l.worst_damping_ratio << ',' << l.limiting_human.mass_kg << ',' << l.limiting_human.damping_Ns_per_m << ','
        << l.limiting_human.stiffness_N_per_m << ',' << l.limiting_human.force_N << '\n';
  }
  out.precision(precision);
}

}  // namespace teleop::analysis
