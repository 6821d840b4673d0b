// The `stability:` section (docs/stability.md, "In the processes").

#include "sections.hpp"

namespace teleop::config::sections {

void ParseStability(const Field& f, int dof, StabilityConfig& stability) {
  const Map map(f, {"check", "peer_delay_samples", "peer_delay_fraction", "unilateral", "human_bounds",
                    "human_grid_steps", "peer", "device"});
  if (auto v = map.Optional("check")) stability.check = v->AsBool();
  if (auto v = map.Optional("peer_delay_samples")) stability.peer_delay_samples = IntInRange(*v, 0, 1);
  if (auto v = map.Optional("peer_delay_fraction")) {
    stability.peer_delay_fraction = InRange(*v, 0.0, 1.0, "(data age / period)");
  }
  if (auto v = map.Optional("unilateral")) stability.unilateral = v->AsBool();
  if (auto v = map.Optional("human_bounds")) stability.human_bounds = v->AsString();
  // 8 steps = 8^3 operators per force level: about 8x the default's start-up time.
  if (auto v = map.Optional("human_grid_steps")) stability.human_grid_steps = IntInRange(*v, 1, 8);
  if (auto v = map.Optional("peer")) {
    const Map peer(*v, {"mass_kg", "damping_Ns_per_m", "kp_N_per_m", "kd_Ns_per_m", "kv_Ns_per_m", "kf",
                        "fixture_stiffness_N_per_m"});
    StabilityConfig::Peer& p = stability.peer;
    if (auto m = peer.Optional("mass_kg")) p.mass_kg = Positive(*m, "kg");
    if (auto b = peer.Optional("damping_Ns_per_m")) p.damping_Ns_per_m = NonNegative(*b, "N·s/m");
    if (peer.Has("kp_N_per_m")) p.kp_N_per_m = ReadGain(peer, "kp_N_per_m", dof, true, "N/m");
    if (peer.Has("kd_Ns_per_m")) p.kd_Ns_per_m = ReadGain(peer, "kd_Ns_per_m", dof, true, "N·s/m");
    if (peer.Has("kv_Ns_per_m")) p.kv_Ns_per_m = ReadGain(peer, "kv_Ns_per_m", dof, true, "N·s/m");
    if (auto k = peer.Optional("kf")) p.kf = ReadDofVector(*k, dof, Finite);
    if (auto k = peer.Optional("fixture_stiffness_N_per_m")) p.fixture_stiffness_N_per_m = NonNegative(*k, "N/m");
  }
  if (auto v = map.Optional("device")) {
    const Map device(*v, {"mass_kg", "damping_Ns_per_m"});
    if (auto m = device.Optional("mass_kg")) stability.device.mass_kg = Positive(*m, "kg");
    if (auto b = device.Optional("damping_Ns_per_m")) stability.device.damping_Ns_per_m = NonNegative(*b, "N·s/m");
  }
}

}  // namespace teleop::config::sections
