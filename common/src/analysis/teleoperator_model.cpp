#include "teleop/analysis/teleoperator_model.hpp"

#include <cmath>
#include <sstream>
#include <string>

#include "teleop/error.hpp"

namespace teleop::analysis {
namespace {

std::string Describe(const char* field, double value, const char* requirement) {
  std::ostringstream out;
  out << "stability analysis: " << field << " = " << value << " " << requirement;
  return out.str();
}

void RequireFinite(const char* field, double value) {
  if (!std::isfinite(value)) throw Error(Describe(field, value, "must be a finite number"));
}

void RequireNonNegative(const char* field, double value) {
  RequireFinite(field, value);
  if (value < 0.0) throw Error(Describe(field, value, "must be >= 0"));
}

void RequirePositive(const char* field, double value) {
  RequireFinite(field, value);
  if (value <= 0.0) throw Error(Describe(field, value, "must be > 0"));
}

}  // namespace

void Validate(const SampledTeleoperator& system) {
  RequirePositive("master mass_kg", system.master.mass_kg);
  RequireNonNegative("master damping_Ns_per_m", system.master.damping_Ns_per_m);
  RequirePositive("slave mass_kg", system.slave.mass_kg);
  RequireNonNegative("slave damping_Ns_per_m", system.slave.damping_Ns_per_m);
  RequirePositive("rate_hz", system.rate_hz);
  if (system.rate_hz < 1.0 || system.rate_hz > 1e6) {
    throw Error(Describe("rate_hz", system.rate_hz, "is outside 1 Hz .. 1 MHz"));
  }
  RequireNonNegative("velocity_filter_hz", system.velocity_filter_hz);
  if (system.velocity_filter_hz >= 0.5 * system.rate_hz) {
    throw Error(Describe("velocity_filter_hz", system.velocity_filter_hz,
                         "must be below the Nyquist frequency (half the rate); use 0 for no filter"));
  }
  if (system.peer_delay_samples != 0 && system.peer_delay_samples != 1) {
    throw Error(Describe("peer_delay_samples", system.peer_delay_samples,
                         "must be 0 (paper's model) or 1 (processes over a link)"));
  }
  if (!std::isfinite(system.peer_delay_fraction) || system.peer_delay_fraction < 0.0 ||
      system.peer_delay_fraction > 1.0) {
    throw Error(Describe("peer_delay_fraction", system.peer_delay_fraction,
                         "must be in 0..1 (peer data age as a fraction of the period)"));
  }
  if (system.slave_peer_delay_fraction &&
      (!std::isfinite(*system.slave_peer_delay_fraction) || *system.slave_peer_delay_fraction < 0.0 ||
       *system.slave_peer_delay_fraction > 1.0)) {
    throw Error(Describe("slave_peer_delay_fraction", *system.slave_peer_delay_fraction,
                         "must be in 0..1 (the slave's peer data age / period)"));
  }
  if (system.peer_delay_samples != 0 && system.peer_delay_fraction != 0.0) {
    throw Error(Describe("peer_delay_fraction", system.peer_delay_fraction,
                         "must be 0 with peer_delay_samples = 1 (the model covers a delay of at most one period; "
                         "use peer_delay_fraction = 1 or peer_delay_samples = 1)"));
  }
  const LawGains& g = system.gains;
  RequireNonNegative("kpm_N_per_m", g.kpm_N_per_m);
  RequireNonNegative("kps_N_per_m", g.kps_N_per_m);
  RequireFinite("kdm_Ns_per_m", g.kdm_Ns_per_m);
  RequireFinite("kds_Ns_per_m", g.kds_Ns_per_m);
  RequireFinite("kvm_Ns_per_m", g.kvm_Ns_per_m);
  RequireFinite("kvs_Ns_per_m", g.kvs_Ns_per_m);
  RequireFinite("kfm", g.kfm);
  RequireNonNegative("master fixture stiffness_N_per_m", g.master_fixture_N_per_m);
  RequireNonNegative("slave fixture stiffness_N_per_m", g.slave_fixture_N_per_m);
}

void Validate(const HumanModel& human) {
  RequirePositive("human mass_kg", human.mass_kg);
  RequireNonNegative("human damping_Ns_per_m", human.damping_Ns_per_m);
  RequireNonNegative("human stiffness_N_per_m", human.stiffness_N_per_m);
  RequireFinite("human force_N", human.force_N);
}

LawGains EffectiveGains(const SampledTeleoperator& system, FixtureSide side) noexcept {
  LawGains g = system.gains;
  if (system.unilateral) {
    g.kpm_N_per_m = 0.0;
    g.kdm_Ns_per_m = 0.0;
    g.kfm = 0.0;
    if (side == FixtureSide::kSlave) {
      g.kvm_Ns_per_m = 0.0;
      g.master_fixture_N_per_m = 0.0;
    }
  }
  return g;
}

}  // namespace teleop::analysis
