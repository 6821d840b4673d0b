// The `passivity:` section (docs/configuration.md, docs/stability.md "Time-domain passivity").

#include <string>

#include "sections.hpp"

namespace teleop::config::sections {

void ParsePassivity(const Field& f, int dof, const link::LinkConfig& link,
                    control::PassivityController::Config& passivity) {
  const Map map(f, {"mode", "max_damping_Ns_per_m"});
  if (auto v = map.Optional("mode")) {
    const std::string mode = v->AsString();
    if (mode == "off") {
      passivity.mode = control::PassivityMode::kOff;
    } else if (mode == "observer") {
      passivity.mode = control::PassivityMode::kObserver;
    } else if (mode == "energy_exchange") {
      passivity.mode = control::PassivityMode::kEnergyExchange;
      if (link.transport != "udp") {
        v->Fail(
            "energy_exchange needs the energy block in every sample, which the CAN frame layout has no room "
            "for (docs/can.md); over transport '" +
            link.transport + "' use mode 'observer' (the local passivity observer/controller)");
      }
    } else {
      v->Fail("must be 'off', 'observer' or 'energy_exchange', got '" + mode + "'");
    }
  }
  passivity.dof = dof;
  const bool active = passivity.mode != control::PassivityMode::kOff;
  if (active && !map.Has("max_damping_Ns_per_m")) {
    map.self().Fail(std::string("max_damping_Ns_per_m is required with mode ") + control::ToString(passivity.mode) +
                    " (the bound on the controller's damping, N·s/m per DOF; docs/stability.md)");
  }
  if (auto v = map.Optional("max_damping_Ns_per_m")) {
    passivity.max_damping_Ns_per_m =
        ReadDofVector(*v, dof, [](const Field& e) { return InRange(e, 1e-9, 1e6, "N·s/m (> 0)"); });
  } else {
    passivity.max_damping_Ns_per_m = ZeroDof(dof);
  }
}

}  // namespace teleop::config::sections
