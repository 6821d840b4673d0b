#include <cmath>
#include <limits>
#include <string>

#include "teleop/device/loopback.hpp"
#include "teleop/error.hpp"
#include "validate.hpp"

namespace teleop::device {
namespace {

using loopback_detail::Fail;
using loopback_detail::RequireNonNegative;

DofVector InitialVector(const DofVector& given, int dof, const char* name) {
  if (given.size() == 0) return DofVector::Zero(dof);
  if (given.size() != dof) {
    Fail(std::string(name) + " has " + std::to_string(given.size()) + " entries; give dof = " + std::to_string(dof) +
         " or none");
  }
  if (!AllFinite(given)) Fail(std::string(name) + " has a non-finite entry");
  return given;
}

}  // namespace

LoopbackPlantConfig LoopbackPlantConfig::PaperMaster(int dof) {
  LoopbackPlantConfig config;  // the struct's defaults are the paper's master
  config.dof = dof;
  return config;
}

LoopbackPlantConfig LoopbackPlantConfig::PaperSlave(int dof) {
  LoopbackPlantConfig config;
  config.dof = dof;
  config.mass_kg = 0.036;
  config.damping_Ns_per_m = 0.49;
  return config;
}

LoopbackPlant::LoopbackPlant(const LoopbackPlantConfig& config) : config_(config) {
  const int dof = config.dof;
  if (dof < 1 || dof > kMaxDof) {
    Fail("dof " + std::to_string(dof) + " is out of range; use 1.." + std::to_string(kMaxDof));
  }
  if (!std::isfinite(config.mass_kg) || config.mass_kg <= 0.0) {
    Fail("mass_kg = " + std::to_string(config.mass_kg) + " must be finite and > 0");
  }
  RequireNonNegative(config.damping_Ns_per_m, "damping_Ns_per_m");
  RequireNonNegative(config.encoder_resolution_m, "encoder_resolution_m");
  if (config.force_sensor_noise_N != 0.0) {
    Fail("force_sensor_noise_N is reserved and must be 0 (no sensor noise model yet)");
  }
  if (config.contact_substeps < 1 || config.contact_substeps > 10000) {
    Fail("contact_substeps " + std::to_string(config.contact_substeps) + " is out of range; use 1..10000");
  }
  script_ = OperatorScript(config.human, dof);
  environment_ = SimulatedEnvironment(config.environment, dof);

  position_m_ = InitialVector(config.initial_position_m, dof, "initial_position_m");
  velocity_m_per_s_ = InitialVector(config.initial_velocity_m_per_s, dof, "initial_velocity_m_per_s");
  command_N_ = DofVector::Zero(dof);
  disturbance_N_ = DofVector::Zero(dof);

  total_mass_kg_ = config.mass_kg;
  total_damping_Ns_per_m_ = config.damping_Ns_per_m;
  if (config.human.enabled) {
    total_mass_kg_ += config.human.mass_kg;
    total_damping_Ns_per_m_ += config.human.damping_Ns_per_m;
    total_stiffness_N_per_m_ = config.human.stiffness_N_per_m;
  }

  capabilities_.dof = dof;
  capabilities_.rendering = Rendering::kActiveForce;
  capabilities_.max_force_N = DofVector::Constant(dof, std::numeric_limits<double>::infinity());  // an ideal motor
  capabilities_.measures_velocity = false;  // like the paper's rig: the law differentiates the encoder
  capabilities_.measures_force = true;
}

double LoopbackPlant::ExternalForce(int axis, double time_s) const noexcept {
  return script_.TargetForce(axis, time_s, disturbance_N_[axis]);
}

DofVector LoopbackPlant::OperatorTargetForce() const noexcept {
  DofVector force_N = DofVector::Zero(config_.dof);
  if (!config_.human.enabled) return force_N;
  for (int axis = 0; axis < config_.dof; ++axis) force_N[axis] = ExternalForce(axis, time_s_) - disturbance_N_[axis];
  return force_N;
}

void LoopbackPlant::CacheSteps(double period_s) noexcept {
  cached_period_s_ = period_s;
  free_period_ =
      analysis::DiscretizeMassSpringDamper(total_mass_kg_, total_damping_Ns_per_m_, total_stiffness_N_per_m_, period_s);
  const double substep_s = period_s / static_cast<double>(config_.contact_substeps);
  free_substep_ = analysis::DiscretizeMassSpringDamper(total_mass_kg_, total_damping_Ns_per_m_,
                                                       total_stiffness_N_per_m_, substep_s);
  contact_substep_ = analysis::DiscretizeMassSpringDamper(
      total_mass_kg_, total_damping_Ns_per_m_ + config_.environment.damping_Ns_per_m,
      total_stiffness_N_per_m_ + config_.environment.stiffness_N_per_m, substep_s);
}

namespace {
inline void Advance(const analysis::ZohBlock& s, double u, double& x, double& v) noexcept {
  const double x_next = s.phi(0, 0) * x + s.phi(0, 1) * v + s.gamma(0) * u;
  const double v_next = s.phi(1, 0) * x + s.phi(1, 1) * v + s.gamma(1) * u;
  x = x_next;
  v = v_next;
}
}  // namespace

void LoopbackPlant::Update(double period_s) noexcept {
  if (!std::isfinite(period_s) || period_s <= 0.0) {
    ++rejected_updates_;
    pending_faults_ |= kFaultDriver;
    return;
  }
  if (period_s != cached_period_s_) CacheSteps(period_s);
  for (int axis = 0; axis < config_.dof; ++axis) {
    const double u = command_N_[axis] + ExternalForce(axis, time_s_);  // held over the period
    double x = position_m_[axis];
    double v = velocity_m_per_s_[axis];
    if (environment_.OnAxis(axis)) {
      double x_free = x;
      double v_free = v;
      Advance(free_period_, u, x_free, v_free);
      const double wall_m = config_.environment.position_m;
      if (x > wall_m || x_free > wall_m) {
        // Contact mode: (m)ẍ + (b + b_w)ẋ + (k + k_w)x = u + k_w·p while the wall pushes (k_w·d + b_w·ẋ > 0).
        const double u_contact = u + config_.environment.stiffness_N_per_m * wall_m;
        for (int i = 0; i < config_.contact_substeps; ++i) {
          if (environment_.Push_N(x, v) > 0.0) {
            Advance(contact_substep_, u_contact, x, v);
          } else {
            Advance(free_substep_, u, x, v);
          }
        }
      } else {
        x = x_free;
        v = v_free;
      }
    } else {
      Advance(free_period_, u, x, v);
    }
    position_m_[axis] = x;
    velocity_m_per_s_[axis] = v;
  }
  time_s_ += period_s;
}

DofVector LoopbackPlant::SensedForce() const noexcept {
  DofVector force_N = DofVector::Zero(config_.dof);
  for (int axis = 0; axis < config_.dof; ++axis) {
    const double x = position_m_[axis];
    const double v = velocity_m_per_s_[axis];
    const double wall_push_N = environment_.OnAxis(axis) ? environment_.Push_N(x, v) : 0.0;
    if (config_.human.enabled) {
      // F_h = F_h* - m_h·ẍ - b_h·ẋ - k_h·x, with ẍ from the device's equation under the held command.
      const double target_N = ExternalForce(axis, time_s_) - disturbance_N_[axis];
      const double total_N = ExternalForce(axis, time_s_) + command_N_[axis] - wall_push_N -
                             total_damping_Ns_per_m_ * v - total_stiffness_N_per_m_ * x;
      const double acceleration = total_N / total_mass_kg_;
      force_N[axis] = target_N - config_.human.mass_kg * acceleration - config_.human.damping_Ns_per_m * v -
                      config_.human.stiffness_N_per_m * x;
    } else {
      force_N[axis] = wall_push_N;  // F_e of eq. 4: what the slave exerts on its environment
    }
  }
  return force_N;
}

void LoopbackPlant::Read(Reading& out) noexcept {
  out.position_m = position_m_;
  if (config_.encoder_resolution_m > 0.0) {
    const double q = config_.encoder_resolution_m;
    for (int axis = 0; axis < config_.dof; ++axis) out.position_m[axis] = std::round(position_m_[axis] / q) * q;
  }
  out.velocity_m_per_s = velocity_m_per_s_;
  out.force_N = SensedForce();
  out.rendered_force_N = command_N_;  // an ideal actuator: what was held over the last period
  out.faults = pending_faults_;
  out.clutch_pressed = clutch_pressed_;
  if (!AllFinite(out.position_m) || !AllFinite(out.velocity_m_per_s) || !AllFinite(out.force_N)) {
    out.faults |= kFaultNonFiniteSensor;
  }
  pending_faults_ = kFaultNone;
}

void LoopbackPlant::Write(const Command& command) noexcept {
  const DofVector& command_N = command.force_N;
  if (command_N.size() != config_.dof || !AllFinite(command_N)) {
    command_N_.setZero();
    ++rejected_commands_;
    pending_faults_ |= kFaultDriver;
    return;
  }
  command_N_ = command_N;
}

void LoopbackPlant::SetSafe() noexcept { command_N_.setZero(); }

void LoopbackPlant::SetDisturbance(const DofVector& force_N) noexcept {
  if (force_N.size() != config_.dof || !AllFinite(force_N)) {
    disturbance_N_.setZero();
    return;
  }
  disturbance_N_ = force_N;
}

}  // namespace teleop::device
