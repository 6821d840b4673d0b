#include "passivity_port.hpp"

namespace teleop::node {

PassivityPort::PassivityPort(const Config& config) : controller_(config) {
  state_.input.peer_input_energy_J = ZeroDof(config.dof);
}

PassivityPort::Output PassivityPort::Step(const Input& in, double period_s) noexcept {
  control::PassivityController::Input& pin = state_.input;
  pin.force_N = *in.force_N;
  pin.velocity_m_per_s = *in.velocity_m_per_s;
  pin.may_act = in.may_act;
  pin.peer_energy_valid = in.peer != nullptr && in.peer->has_energy;
  if (pin.peer_energy_valid) {
    const int dof = controller_.config().dof;
    pin.peer_input_energy_J.resize(dof);
    for (int i = 0; i < dof; ++i) pin.peer_input_energy_J[i] = in.peer->input_energy_J[static_cast<std::size_t>(i)];
  } else if (in.peer != nullptr && controller_.config().mode == control::PassivityMode::kEnergyExchange) {
    ++state_.peer_without_energy;
  }
  const control::PassivityController::Output pc = controller_.Step(pin, period_s);
  Output out;
  out.force_N = pc.force_N;
  out.damping_Ns_per_m = pc.damping_Ns_per_m;
  const control::PassivityController::State& s = controller_.state();
  out.energies.input_energy_J = s.input_energy_J;
  out.energies.output_energy_J = s.output_energy_J;
  out.energies.observed_J = s.observed_J;
  return out;
}

}  // namespace teleop::node
