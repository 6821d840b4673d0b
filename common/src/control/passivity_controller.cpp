#include "teleop/control/passivity_controller.hpp"

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

void PassivityController::SwitchMode(PassivityMode mode) noexcept {
  if (mode != PassivityMode::kOff && mode != PassivityMode::kObserver && mode != PassivityMode::kEnergyExchange) return;
  if (mode == config_.mode) return;
  config_.mode = mode;
  state_.rebase_pending = true;  // the next Step settles the interval before the switch, then W starts at 0
}

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
    state_.has_last = false;  // the interval's force is unknown: the next step starts a new one
    return out;
  }
  bool acted = false;
  bool saturated = false;
  for (int i = 0; i < dof; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const double u = input.force_N[i];
    const double v = input.velocity_m_per_s[i];
    double& w = state_.observed_J[k];

    // 1. Observer: the work of the force held over the last interval, [n-1, n]. With v(n) the backward difference
    //    (x(n) - x(n-1))/T this is exact: the law's share u(n-1)·Δx, the damper's -α(n-1)·v(n-1)·Δx.
    if (state_.has_last) {
      const double law_J = state_.last_law_force_N[k] * v * period_s;
      const double damper_J = state_.last_damping_Ns_per_m[k] * state_.last_velocity_m_per_s[k] * v * period_s;
      if (law_J < 0.0) {
        state_.input_energy_J[k] -= law_J;
        if (!exchange) w -= law_J;  // observer (and off): what this port absorbed it may give back
      } else {
        state_.output_energy_J[k] += law_J;
        w -= law_J;
      }
      state_.dissipated_J[k] += damper_J;
      w += damper_J;
    }
    if (state_.rebase_pending) {  // SwitchMode: passive from the switch on; the deficit before it stays on record
      state_.min_observed_J = std::min(state_.min_observed_J, w);
      w = 0.0;
    }
    if (exchange && input.peer_energy_valid) {
      const double peer = input.peer_input_energy_J[i];
      if (std::isfinite(peer) && peer >= 0.0) {
        if (peer > state_.peer_base_J[k]) w += peer - state_.peer_base_J[k];
        state_.peer_base_J[k] = peer;  // a decrease is a restarted peer: new base, no credit
      }
    }
    state_.min_observed_J = std::min(state_.min_observed_J, w);

    // 2. Controller: the coming interval would deliver about u·v·T; a damper takes out exactly what W cannot cover.
    const double v2t = v * v * period_s;
    const double coming_J = u * v * period_s;
    const double predicted = w - (exchange ? std::max(0.0, coming_J) : coming_J);
    const double alpha_max = config_.max_damping_Ns_per_m[i];
    double alpha = 0.0;
    // Rounding of the cumulative sums is not a deficit.
    const double tolerance_J = 1e-15 + 1e-12 * (state_.output_energy_J[k] + std::fabs(coming_J));
    if (predicted < -tolerance_J && config_.mode != PassivityMode::kOff && input.may_act) {
      if (alpha_max > 0.0 && v2t > 0.0) {
        alpha = std::min(-predicted / v2t, alpha_max);
        double u_pc = u - alpha * v;
        if (config_.max_force_N > 0.0 && std::fabs(u_pc) > config_.max_force_N) {
          // |u| ≤ max (the law saturates), so the clamped force lies between u and u - α·v: 0 ≤ α' ≤ α.
          u_pc = std::clamp(u_pc, -config_.max_force_N, config_.max_force_N);
          alpha = std::max(0.0, (u - u_pc) / v);
        }
        out.force_N[i] = u_pc;
      }
      if (predicted + alpha * v2t < -tolerance_J) saturated = true;
    }
    out.damping_Ns_per_m[i] = alpha;
    acted = acted || alpha > 0.0;
    state_.last_law_force_N[k] = u;
    state_.last_damping_Ns_per_m[k] = alpha;
    state_.last_velocity_m_per_s[k] = v;
  }
  state_.has_last = true;
  state_.rebase_pending = false;
  out.acted = acted;
  if (acted) ++state_.acting_steps;
  if (saturated) ++state_.saturated_steps;
  return out;
}

}  // namespace teleop::control
