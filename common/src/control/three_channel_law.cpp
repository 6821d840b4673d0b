#include "teleop/control/three_channel_law.hpp"

#include <cmath>
#include <string>

#include "teleop/error.hpp"

namespace teleop::control {
namespace {

[[noreturn]] void Fail(const std::string& message) { throw Error("three-channel law: " + message); }

void CheckGain(const DofVector& gain, const char* name, int dof, bool non_negative) {
  if (gain.size() != dof) {
    Fail(std::string(name) + " has " + std::to_string(gain.size()) +
         " entries; give exactly dof = " + std::to_string(dof) + " (one per DOF)");
  }
  for (int i = 0; i < dof; ++i) {
    if (!std::isfinite(gain[i])) Fail(std::string(name) + "[" + std::to_string(i) + "] is not finite");
    if (non_negative && gain[i] < 0.0) {
      Fail(std::string(name) + "[" + std::to_string(i) + "] = " + std::to_string(gain[i]) +
           " is negative; gains must be >= 0");
    }
  }
}

ThreeChannelLaw::Config Validated(ThreeChannelLaw::Config config) {
  if (config.role != Role::kMaster && config.role != Role::kSlave) Fail("role must be master or slave");
  if (config.dof < 1 || config.dof > kMaxDof) {
    Fail("dof " + std::to_string(config.dof) + " is out of range; use 1.." + std::to_string(kMaxDof));
  }
  CheckGain(config.kp_N_per_m, "kp_N_per_m", config.dof, true);
  CheckGain(config.kd_Ns_per_m, "kd_Ns_per_m", config.dof, true);
  CheckGain(config.kv_Ns_per_m, "kv_Ns_per_m", config.dof, true);
  CheckGain(config.kf, "kf", config.dof, false);
  if (config.role == Role::kSlave && !config.kf.isZero(0.0)) {
    Fail("kf is the master's force feed-forward (eq. 8); the slave law (eq. 9) has none: set kf to 0 on the slave");
  }
  if (!std::isfinite(config.peer_position_scale) || config.peer_position_scale == 0.0) {
    Fail("peer_position_scale must be finite and non-zero (1 = same scale on both sides)");
  }
  if (!std::isfinite(config.peer_force_scale)) Fail("peer_force_scale must be finite");
  if (!std::isfinite(config.max_force_N) || config.max_force_N < 0.0) {
    Fail("max_force_N " + std::to_string(config.max_force_N) + " must be finite and >= 0 (0 = no limit)");
  }
  if (!std::isfinite(config.velocity_filter_hz) || config.velocity_filter_hz < 0.0) {
    Fail("velocity_filter_hz " + std::to_string(config.velocity_filter_hz) + " must be finite and >= 0 (0 = off)");
  }
  if (config.fixture.dof != config.dof) {
    if (config.fixture.plane_count == 0 && config.fixture.stiffness_N_per_m == 0.0) {
      config.fixture.dof = config.dof;  // the disabled default fixture
    } else {
      Fail("fixture has dof " + std::to_string(config.fixture.dof) + " but the law has dof " +
           std::to_string(config.dof));
    }
  }
  return config;
}

bool SizedAndFinite(const DofVector& v, int dof) noexcept { return v.size() == dof && AllFinite(v); }

}  // namespace

ThreeChannelLaw::ThreeChannelLaw() : ThreeChannelLaw(ZeroGains(Role::kMaster, 1)) {}

ThreeChannelLaw::ThreeChannelLaw(const Config& config)
    : config_(Validated(config)),
      fixture_(config_.fixture),
      state_{VelocityEstimator({config_.dof, config_.velocity_filter_hz})} {}

void ThreeChannelLaw::SetGains(const DofVector& kp_N_per_m, const DofVector& kd_Ns_per_m, const DofVector& kv_Ns_per_m,
                               const DofVector& kf) noexcept {
  const int dof = config_.dof;
  const auto gain_ok = [dof](const DofVector& g) { return SizedAndFinite(g, dof) && (g.array() >= 0.0).all(); };
  if (!gain_ok(kp_N_per_m) || !gain_ok(kd_Ns_per_m) || !gain_ok(kv_Ns_per_m) || !SizedAndFinite(kf, dof)) return;
  if (config_.role == Role::kSlave && !kf.isZero(0.0)) return;
  config_.kp_N_per_m = kp_N_per_m;
  config_.kd_Ns_per_m = kd_Ns_per_m;
  config_.kv_Ns_per_m = kv_Ns_per_m;
  config_.kf = kf;
}

ThreeChannelLaw::Config ThreeChannelLaw::ZeroGains(Role role, int dof) {
  if (dof < 1 || dof > kMaxDof) Fail("dof " + std::to_string(dof) + " is out of range");
  Config config;
  config.role = role;
  config.dof = dof;
  config.kp_N_per_m = DofVector::Zero(dof);
  config.kd_Ns_per_m = DofVector::Zero(dof);
  config.kv_Ns_per_m = DofVector::Zero(dof);
  config.kf = DofVector::Zero(dof);
  config.fixture.dof = dof;
  return config;
}

ThreeChannelLaw::Output ThreeChannelLaw::Step(const Input& input, double period_s) noexcept {
  const int dof = config_.dof;
  Output out;
  out.command_N = DofVector::Zero(dof);
  out.fixture_force_N = DofVector::Zero(dof);
  out.velocity_m_per_s = DofVector::Zero(dof);
  ++state_.steps;

  const bool period_ok = std::isfinite(period_s) && period_s > 0.0;
  const bool position_ok = SizedAndFinite(input.position_m, dof);
  const bool velocity_ok = !input.has_velocity || SizedAndFinite(input.velocity_m_per_s, dof);
  const bool peer_ok = !input.peer_valid ||
                       (SizedAndFinite(input.peer_position_m, dof) &&
                        SizedAndFinite(input.peer_velocity_m_per_s, dof) && SizedAndFinite(input.peer_force_N, dof));
  if (!position_ok) state_.velocity.Reset();
  if (!period_ok || !position_ok || !velocity_ok || !peer_ok) {
    ++state_.nonfinite_inputs;
    out.status = StepStatus::kNonFiniteInput;
    return out;
  }

  // Keep the estimator running even when a velocity sensor is used, so switching sources is seamless.
  const DofVector& estimated = state_.velocity.Step(input.position_m, period_s);
  out.velocity_m_per_s = input.has_velocity ? input.velocity_m_per_s : estimated;

  const ForbiddenRegionFixture::Output fixture = fixture_.Step(input.position_m);
  out.fixture_force_N = fixture.force_N;
  out.fixture_penetration_m = fixture.max_penetration_m;

  // Local terms: -K_v·Ẋ_l + fixture force (= -F_VF).
  out.command_N = fixture.force_N - config_.kv_Ns_per_m.cwiseProduct(out.velocity_m_per_s);

  if (input.peer_valid) {
    const double s = config_.peer_position_scale;
    const double f = config_.peer_force_scale;
    out.command_N -= config_.kp_N_per_m.cwiseProduct(input.position_m - s * input.peer_position_m);
    out.command_N -= config_.kd_Ns_per_m.cwiseProduct(out.velocity_m_per_s - s * input.peer_velocity_m_per_s);
    out.command_N -= config_.kf.cwiseProduct(f * input.peer_force_N);
  } else {
    ++state_.peer_missing_steps;
    out.status = StepStatus::kPeerMissing;
  }

  if (!AllFinite(out.command_N)) {  // finite inputs times finite gains can still overflow
    out.command_N.setZero();
    ++state_.nonfinite_inputs;
    out.status = StepStatus::kNonFiniteInput;
    return out;
  }

  if (config_.max_force_N > 0.0) {
    bool saturated = false;
    for (int i = 0; i < dof; ++i) {
      if (out.command_N[i] > config_.max_force_N) {
        out.command_N[i] = config_.max_force_N;
        saturated = true;
      } else if (out.command_N[i] < -config_.max_force_N) {
        out.command_N[i] = -config_.max_force_N;
        saturated = true;
      }
    }
    if (saturated) {
      ++state_.saturated_steps;
      if (out.status == StepStatus::kOk) out.status = StepStatus::kSaturated;
    }
  }
  return out;
}

void ThreeChannelLaw::Reset() noexcept {
  state_.velocity.Reset();
  state_.steps = 0;
  state_.saturated_steps = 0;
  state_.nonfinite_inputs = 0;
  state_.peer_missing_steps = 0;
}

const char* ToString(ThreeChannelLaw::StepStatus status) noexcept {
  switch (status) {
    case ThreeChannelLaw::StepStatus::kOk:
      return "ok";
    case ThreeChannelLaw::StepStatus::kSaturated:
      return "saturated";
    case ThreeChannelLaw::StepStatus::kPeerMissing:
      return "peer-missing";
    case ThreeChannelLaw::StepStatus::kNonFiniteInput:
      return "non-finite-input";
  }
  return "unknown";
}

}  // namespace teleop::control
