#include "teleop/analysis/teleoperator_model.hpp"

#include <cmath>
#include <cstdio>
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
  const auto check_samples = [](const char* field, int samples) {
    if (samples < 0 || samples > kMaxPeerDelaySamples) {
      throw Error(Describe(field, samples,
                           ("must be 0 (paper's model), 1 (processes over a link) or up to " +
                            std::to_string(kMaxPeerDelaySamples) + " (a link with delay)")
                               .c_str()));
    }
  };
  const auto check_fraction = [](const char* field, double fraction) {
    if (!std::isfinite(fraction) || fraction < 0.0 || fraction > 1.0) {
      throw Error(Describe(field, fraction, "must be in 0..1 (peer data age beyond the whole samples / period)"));
    }
  };
  check_samples("peer_delay_samples", system.peer_delay_samples);
  check_fraction("peer_delay_fraction", system.peer_delay_fraction);
  if (system.slave_peer_delay_samples) check_samples("slave_peer_delay_samples", *system.slave_peer_delay_samples);
  if (system.slave_peer_delay_fraction) check_fraction("slave_peer_delay_fraction", *system.slave_peer_delay_fraction);
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

PeerDelays PeerDelaysOf(const SampledTeleoperator& system) noexcept {
  PeerDelays d;
  d.slave_to_master_samples = system.peer_delay_samples;
  d.slave_to_master_fraction = system.peer_delay_fraction;
  if (system.slave_peer_delay_samples || system.slave_peer_delay_fraction) {
    d.master_to_slave_samples = system.slave_peer_delay_samples.value_or(0);
    d.master_to_slave_fraction = system.slave_peer_delay_fraction.value_or(0.0);
  } else {
    d.master_to_slave_samples = d.slave_to_master_samples;
    d.master_to_slave_fraction = d.slave_to_master_fraction;
  }
  return d;
}

void SetPeerDelays(SampledTeleoperator& system, double slave_to_master_samples, double master_to_slave_samples) {
  const auto split = [](const char* field, double samples, int& whole, double& fraction) {
    if (!std::isfinite(samples) || samples < 0.0 || samples > kMaxPeerDelaySamples + 1.0) {
      throw Error(
          Describe(field, samples, ("must be in 0.." + std::to_string(kMaxPeerDelaySamples) + " samples").c_str()));
    }
    whole = static_cast<int>(std::floor(samples));
    fraction = samples - whole;
    if (whole > kMaxPeerDelaySamples) {
      whole = kMaxPeerDelaySamples;
      fraction = 1.0;
    }
  };
  split("slave->master delay", slave_to_master_samples, system.peer_delay_samples, system.peer_delay_fraction);
  int whole = 0;
  double fraction = 0.0;
  split("master->slave delay", master_to_slave_samples, whole, fraction);
  system.slave_peer_delay_samples = whole;
  system.slave_peer_delay_fraction = fraction;
}

void AddLinkDelay(SampledTeleoperator& system, double link_delay_s) {
  if (!std::isfinite(link_delay_s) || link_delay_s < 0.0) {
    throw Error(Describe("link delay (s)", link_delay_s, "must be a finite number >= 0"));
  }
  const PeerDelays d = PeerDelaysOf(system);
  const double extra = link_delay_s * system.rate_hz;
  SetPeerDelays(system, d.slave_to_master() + extra, d.master_to_slave() + extra);
}

std::string DescribePeerDelay(const SampledTeleoperator& system) {
  const PeerDelays d = PeerDelaysOf(system);
  const auto samples = [](double value) {
    char text[48];
    std::snprintf(text, sizeof text, "%g sample%s", value, value == 1.0 ? "" : "s");
    return std::string(text);
  };
  if (d.slave_to_master() == d.master_to_slave() && d.slave_to_master_fraction == 0.0) {
    return "peer delay " + samples(d.slave_to_master());
  }
  return "peer delay slave->master " + samples(d.slave_to_master()) + ", master->slave " + samples(d.master_to_slave());
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
