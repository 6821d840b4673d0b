#include "teleop/control/passivity_observer.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "teleop/error.hpp"

namespace teleop::control {
namespace {

[[noreturn]] void Fail(const std::string& message) { throw Error("passivity controller: " + message); }

PassivityController::Config Validated(PassivityController::Config config) {
  if (config.mode != PassivityMode::kOff && config.mode != PassivityMode::kObserver &&
      config.mode != PassivityMode::kEnergyExchange) {
    Fail("mode must be off, observer or energy_exchange");
  }
  if (config.dof < 1 || config.dof > kMaxDof) {
    Fail("dof " + std::to_string(config.dof) + " is out of range; use 1.." + std::to_string(kMaxDof));
  }
  if (config.max_damping_Ns_per_m.size() != config.dof) {
    Fail("max_damping_Ns_per_m has " + std::to_string(config.max_damping_Ns_per_m.size()) +
         " entries; give exactly dof = " + std::to_string(config.dof));
  }
  for (int i = 0; i < config.dof; ++i) {
    const double a = config.max_damping_Ns_per_m[i];
    if (!std::isfinite(a) || a < 0.0) {
      Fail("max_damping_Ns_per_m[" + std::to_string(i) + "] = " + std::to_string(a) + " must be finite and >= 0");
    }
  }
  if (!std::isfinite(config.max_force_N) || config.max_force_N < 0.0) {
    Fail("max_force_N " + std::to_string(config.max_force_N) + " must be finite and >= 0 (0 = no limit)");
  }
  return config;
}

PassivityController::Config DefaultConfig() {
  PassivityController::Config config;
  config.max_damping_Ns_per_m = ZeroDof(1);
  return config;
}

}  // namespace

const char* ToString(PassivityMode mode) noexcept {
  switch (mode) {
    case PassivityMode::kOff:
      return "off";
    case PassivityMode::kObserver:
      return "observer";
    case PassivityMode::kEnergyExchange:
      return "energy_exchange";
  }
  return "invalid";
}

PassivityController::PassivityController() : config_(DefaultConfig()) {}

PassivityController::PassivityController(const Config& config) : config_(Validated(config)) {}

void PassivityController::Reset() noexcept { state_ = State{}; }

double PassivityController::total_dissipated_J() const noexcept {
  double sum = 0.0;
  for (int i = 0; i < config_.dof; ++i) sum += state_.dissipated_J[static_cast<std::size_t>(i)];
  return sum;
}

PassivityController::Output PassivityController::Step(const Input& input, double period_s) noexcept {
  const int dof = config_.dof;
  Output out;
  out.force_N = input.force_N;
  out.damping_Ns_per_m = DofVector::Zero(input.force_N.size());
  ++state_.steps;
  const bool exchange = config_.mode == PassivityMode::kEnergyExchange;
  if (input.force_N.size() != dof || input.velocity_m_per_s.size() != dof ||
      (exchange && input.peer_energy_valid && input.peer_input_energy_J.size() != dof) || !std::isfinite(period_s) ||
      period_s <= 0.0 || !AllFinite(input.force_N) || !AllFinite(input.velocity_m_per_s)) {
    ++state_.nonfinite_inputs;
    return out;
  }
  bool acted = false;
  bool saturated = false;
  for (int i = 0; i < dof; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double u = input.force_N[i];
    const double v = input.velocity_m_per_s[i];
    const double delivered_J = u * v * period_s;  // > 0: the network gives energy to the device this step
    double& w = state_.observed_J[k];

    // Credit: what this port may give out.
    if (exchange) {
      if (input.peer_energy_valid) {
        const double peer = input.peer_input_energy_J[i];
        if (std::isfinite(peer) && peer >= 0.0) {
          if (peer > state_.peer_base_J[k]) w += peer - state_.peer_base_J[k];
          state_.peer_base_J[k] = peer;  // a decrease is a restarted peer: new base, no credit
        }
      }
    } else if (delivered_J < 0.0) {
      w -= delivered_J;  // observer (and off): what this port absorbed it may give back
    }
    if (delivered_J < 0.0) {
      state_.input_energy_J[k] -= delivered_J;
    } else {
      state_.output_energy_J[k] += delivered_J;
      w -= delivered_J;
    }
    state_.min_observed_J = std::min(state_.min_observed_J, w);

    // Controller: a damper that dissipates exactly the deficit, within its bounds.
    const double alpha_max = config_.max_damping_Ns_per_m[i];
    if (w < 0.0 && config_.mode != PassivityMode::kOff && alpha_max > 0.0 && v != 0.0) {
      const double v2t = v * v * period_s;
      double alpha = std::min(-w / v2t, alpha_max);
      double u_pc = u - alpha * v;
      if (config_.max_force_N > 0.0 && std::fabs(u_pc) > config_.max_force_N) {
        // |u| ≤ max (the law saturates), so the clamped force lies between u and u - α·v: 0 ≤ α' ≤ α.
        u_pc = std::clamp(u_pc, -config_.max_force_N, config_.max_force_N);
        alpha = std::max(0.0, (u - u_pc) / v);
      }
      const double dissipated = alpha * v2t;
      if (alpha > 0.0) {
        acted = true;
        out.force_N[i] = u_pc;
        out.damping_Ns_per_m[i] = alpha;
        state_.dissipated_J[k] += dissipated;
        w += dissipated;
      }
      if (w < 0.0) {
        saturated = true;
        // α = -w/(v²T) zeroes w up to rounding; a residue of a few ulp is not a deficit.
        if (-w <= 1e-12 * (std::fabs(dissipated) + std::fabs(delivered_J))) {
          w = 0.0;
          saturated = false;
        }
      }
    } else if (w < 0.0 && config_.mode != PassivityMode::kOff) {
      saturated = true;
    }
  }
  out.acted = acted;
  if (acted) ++state_.acting_steps;
  if (saturated) ++state_.saturated_steps;
  return out;
}

}  // namespace teleop::control
