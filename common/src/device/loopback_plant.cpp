#include "teleop/device/loopback_plant.hpp"

#include <Eigen/Core>
#include <cmath>
#include <numbers>
#include <string>

#include "teleop/error.hpp"

namespace teleop::device {
namespace {

[[noreturn]] void Fail(const std::string& message) { throw Error("loopback plant: " + message); }

void RequireFinite(double value, const std::string& name) {
  if (!std::isfinite(value)) Fail(name + " must be finite");
}

void RequireNonNegative(double value, const std::string& name) {
  if (!std::isfinite(value) || value < 0.0) Fail(name + " = " + std::to_string(value) + " must be finite and >= 0");
}

/// exp(M) for a 3×3 matrix by scaling and squaring with a degree-18 Taylor series: after scaling ‖M‖ ≤ 1/2, so
/// the truncation error is below 2^-19/19! ≈ 1e-23 relative. Fixed-size: no allocation.
Eigen::Matrix3d Expm(const Eigen::Matrix3d& m) noexcept {
  const double norm = m.cwiseAbs().rowwise().sum().maxCoeff();
  int squarings = 0;
  if (norm > 0.5) squarings = static_cast<int>(std::ceil(std::log2(norm / 0.5)));
  if (squarings > 60) squarings = 60;
  const Eigen::Matrix3d scaled = m / std::ldexp(1.0, squarings);
  Eigen::Matrix3d result = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d term = Eigen::Matrix3d::Identity();
  for (int k = 1; k <= 18; ++k) {
    term = (term * scaled) / static_cast<double>(k);
    result += term;
  }
  for (int i = 0; i < squarings; ++i) result = (result * result).eval();
  return result;
}

/// Level of one segment at time t when it is active (hold levels come from the precomputed table).
double SegmentLevel(const OperatorSegment& s, double hold_level_N, double t) noexcept {
  switch (s.kind) {
    case OperatorSegment::Kind::kHold:
      return hold_level_N;
    case OperatorSegment::Kind::kStep:
      return s.to_N;
    case OperatorSegment::Kind::kRamp: {
      double fraction = (t - s.start_s) / s.duration_s;
      if (fraction < 0.0) fraction = 0.0;
      if (fraction > 1.0) fraction = 1.0;
      return s.from_N + (s.to_N - s.from_N) * fraction;
    }
    case OperatorSegment::Kind::kSine:
      return s.offset_N + s.amplitude_N * std::sin(2.0 * std::numbers::pi * s.frequency_hz * (t - s.start_s));
  }
  return 0.0;
}

bool ActiveAt(const OperatorSegment& s, double t) noexcept {
  return t >= s.start_s && (s.duration_s == 0.0 || t < s.start_s + s.duration_s);
}

/// Active just before t (left limit): started strictly before t and not ended before t.
bool ActiveJustBefore(const OperatorSegment& s, double t) noexcept {
  return s.start_s < t && (s.duration_s == 0.0 || t <= s.start_s + s.duration_s);
}

void ValidateOperator(const SimulatedOperatorConfig& human, int dof) {
  if (!human.enabled) return;
  RequireNonNegative(human.mass_kg, "human.mass_kg");
  RequireNonNegative(human.damping_Ns_per_m, "human.damping_Ns_per_m");
  RequireNonNegative(human.stiffness_N_per_m, "human.stiffness_N_per_m");
  if (human.segment_count < 0 || human.segment_count > SimulatedOperatorConfig::kMaxSegments) {
    Fail("human.segment_count " + std::to_string(human.segment_count) + " is out of range; use 0.." +
         std::to_string(SimulatedOperatorConfig::kMaxSegments));
  }
  for (int i = 0; i < human.segment_count; ++i) {
    const OperatorSegment& s = human.segments[static_cast<std::size_t>(i)];
    const std::string which = "human.segments[" + std::to_string(i) + "].";
    if (s.kind != OperatorSegment::Kind::kHold && s.kind != OperatorSegment::Kind::kStep &&
        s.kind != OperatorSegment::Kind::kRamp && s.kind != OperatorSegment::Kind::kSine) {
      Fail(which + "kind is not hold, step, ramp or sine");
    }
    RequireNonNegative(s.start_s, which + "start_s");
    RequireNonNegative(s.duration_s, which + "duration_s");
    if (s.kind == OperatorSegment::Kind::kRamp && s.duration_s <= 0.0) {
      Fail(which + "duration_s must be > 0 for a ramp (follow it with a hold to keep the end level)");
    }
    RequireFinite(s.from_N, which + "from_N");
    RequireFinite(s.to_N, which + "to_N");
    RequireFinite(s.amplitude_N, which + "amplitude_N");
    RequireFinite(s.offset_N, which + "offset_N");
    RequireNonNegative(s.frequency_hz, which + "frequency_hz");
    if (s.axis < 0 || s.axis >= dof) {
      Fail(which + "axis " + std::to_string(s.axis) + " is out of range for dof " + std::to_string(dof));
    }
  }
}

void ValidateEnvironment(const SimulatedEnvironmentConfig& env, int dof) {
  if (env.kind == SimulatedEnvironmentConfig::Kind::kFreeSpace) return;
  if (env.kind != SimulatedEnvironmentConfig::Kind::kWall) Fail("environment.kind is not free space or wall");
  if (env.axis < 0 || env.axis >= dof) {
    Fail("environment.axis " + std::to_string(env.axis) + " is out of range for dof " + std::to_string(dof));
  }
  RequireFinite(env.position_m, "environment.position_m");
  RequireNonNegative(env.stiffness_N_per_m, "environment.stiffness_N_per_m");
  RequireNonNegative(env.damping_Ns_per_m, "environment.damping_Ns_per_m");
}

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
  LoopbackPlantConfig config;
  config.dof = dof;
  config.mass_kg = 0.040;
  config.damping_Ns_per_m = 0.41;
  return config;
}

LoopbackPlantConfig LoopbackPlantConfig::PaperSlave(int dof) {
  LoopbackPlantConfig config;
  config.dof = dof;
  config.mass_kg = 0.036;
  config.damping_Ns_per_m = 0.49;
  return config;
}

LoopbackPlant::ExactStep LoopbackPlant::Discretise(double mass_kg, double damping_Ns_per_m, double stiffness_N_per_m,
                                                   double step_s) noexcept {
  // Augmented system d/dt [x, v, u] = [[0, 1, 0], [-k/m, -b/m, 1/m], [0, 0, 0]]·[x, v, u]: its exponential holds
  // the state transition (top-left 2×2) and the zero-order-hold input response (top-right column).
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  a(0, 1) = 1.0;
  a(1, 0) = -stiffness_N_per_m / mass_kg;
  a(1, 1) = -damping_Ns_per_m / mass_kg;
  a(1, 2) = 1.0 / mass_kg;
  const Eigen::Matrix3d e = Expm(a * step_s);
  ExactStep step;
  step.phi = {e(0, 0), e(0, 1), e(1, 0), e(1, 1)};
  step.gamma = {e(0, 2), e(1, 2)};
  return step;
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
  ValidateOperator(config.human, dof);
  ValidateEnvironment(config.environment, dof);

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
    // Hold levels: the left limit, at the hold's start, of the segments listed before it on the same axis.
    for (int i = 0; i < config.human.segment_count; ++i) {
      const OperatorSegment& hold = config.human.segments[static_cast<std::size_t>(i)];
      if (hold.kind != OperatorSegment::Kind::kHold) continue;
      double level_N = 0.0;
      for (int j = 0; j < i; ++j) {
        const OperatorSegment& s = config.human.segments[static_cast<std::size_t>(j)];
        if (s.axis == hold.axis && ActiveJustBefore(s, hold.start_s)) {
          level_N += SegmentLevel(s, hold_level_N_[static_cast<std::size_t>(j)], hold.start_s);
        }
      }
      hold_level_N_[static_cast<std::size_t>(i)] = level_N;
    }
  }

  capabilities_.dof = dof;
  capabilities_.renders_active_force = true;
  capabilities_.dissipative_only = false;
  capabilities_.steering_constraints = false;
  capabilities_.measures_velocity = false;  // like the paper's rig: the law differentiates the encoder
  capabilities_.measures_force = true;
}

double LoopbackPlant::ExternalForce(int axis, double time_s) const noexcept {
  double force_N = disturbance_N_[axis];
  if (!config_.human.enabled) return force_N;
  for (int i = 0; i < config_.human.segment_count; ++i) {
    const OperatorSegment& s = config_.human.segments[static_cast<std::size_t>(i)];
    if (s.axis == axis && ActiveAt(s, time_s)) {
      force_N += SegmentLevel(s, hold_level_N_[static_cast<std::size_t>(i)], time_s);
    }
  }
  return force_N;
}

DofVector LoopbackPlant::OperatorTargetForce() const noexcept {
  DofVector force_N = DofVector::Zero(config_.dof);
  if (!config_.human.enabled) return force_N;
  for (int axis = 0; axis < config_.dof; ++axis) force_N[axis] = ExternalForce(axis, time_s_) - disturbance_N_[axis];
  return force_N;
}

bool LoopbackPlant::WallAxis(int axis) const noexcept {
  return config_.environment.kind == SimulatedEnvironmentConfig::Kind::kWall && config_.environment.axis == axis;
}

double LoopbackPlant::WallPush(double x, double v) const noexcept {
  const double depth_m = x - config_.environment.position_m;
  if (depth_m <= 0.0) return 0.0;
  const double push_N = config_.environment.stiffness_N_per_m * depth_m + config_.environment.damping_Ns_per_m * v;
  return push_N > 0.0 ? push_N : 0.0;
}

void LoopbackPlant::CacheSteps(double period_s) noexcept {
  cached_period_s_ = period_s;
  free_period_ = Discretise(total_mass_kg_, total_damping_Ns_per_m_, total_stiffness_N_per_m_, period_s);
  const double substep_s = period_s / static_cast<double>(config_.contact_substeps);
  free_substep_ = Discretise(total_mass_kg_, total_damping_Ns_per_m_, total_stiffness_N_per_m_, substep_s);
  contact_substep_ = Discretise(total_mass_kg_, total_damping_Ns_per_m_ + config_.environment.damping_Ns_per_m,
                                total_stiffness_N_per_m_ + config_.environment.stiffness_N_per_m, substep_s);
}

namespace {
inline void Advance(const LoopbackPlant::ExactStep& s, double u, double& x, double& v) noexcept {
  const double x_next = s.phi[0] * x + s.phi[1] * v + s.gamma[0] * u;
  const double v_next = s.phi[2] * x + s.phi[3] * v + s.gamma[1] * u;
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
    if (WallAxis(axis)) {
      double x_free = x;
      double v_free = v;
      Advance(free_period_, u, x_free, v_free);
      const double wall_m = config_.environment.position_m;
      if (x > wall_m || x_free > wall_m) {
        // Contact mode: (m)ẍ + (b + b_w)ẋ + (k + k_w)x = u + k_w·p while the wall pushes (k_w·d + b_w·ẋ > 0).
        const double u_contact = u + config_.environment.stiffness_N_per_m * wall_m;
        for (int i = 0; i < config_.contact_substeps; ++i) {
          if (WallPush(x, v) > 0.0) {
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
    const double wall_push_N = WallAxis(axis) ? WallPush(x, v) : 0.0;
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
  out.faults = pending_faults_;
  if (!AllFinite(out.position_m) || !AllFinite(out.velocity_m_per_s) || !AllFinite(out.force_N)) {
    out.faults |= kFaultNonFiniteSensor;
  }
  pending_faults_ = kFaultNone;
}

void LoopbackPlant::Write(const DofVector& command_N) noexcept {
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
