// The simulated bicycle cobot behind the Device interface (BicycleCobotDevice, cobot_backend.hpp).

#include <cmath>

#include "cobot_backend_private.hpp"

namespace teleop::device::cobot {

namespace {
/// The wall controller of the bicycle's virtual unicycle: the unicycle's, with τ of the steering loop on the
/// bicycle's wheels (K₂ and the wheel inertia are the same).
VirtualWallConfig BicycleWallConfig(const CobotBackendConfig& c) {
  VirtualWallConfig w = c.unicycle.controller;
  w.steering_time_constant_s =
      c.bicycle.steering_inertia_kgm2 / (w.tracker.k2_Nms_per_rad + c.bicycle.steering_damping_Nms_per_rad);
  Validate(w);
  return w;
}
/// Gain that steers each wheel onto the virtual heading (1/s): a quarter of the steering loop's bandwidth.
constexpr double kAlignmentFraction = 0.25;

/// The wheels' common heading modulo π, relative to the plate (the mean of β₀ and β₁ brought within ±π/2 of β₀).
double MeanSteer(const BicyclePlantState& s) noexcept {
  const double b1 = s.steer_rad[0] + 0.5 * WrapAngle(2.0 * (s.steer_rad[1] - s.steer_rad[0]));
  return 0.5 * (s.steer_rad[0] + b1);
}
}  // namespace

double BicycleCobotDevice::virtual_heading_rad() const noexcept { return state_.pose.angle_rad + MeanSteer(state_); }

BicycleCobotDevice::BicycleCobotDevice(const CobotBackendConfig& config)
    : config_(config),
      capabilities_(CobotCapabilities(3, 0.0)),
      controller_(BicycleWallConfig(config), Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true)),
      walls_(config.contact_force_threshold_N),
      sensing_(config.unicycle.sensors, config.unicycle.speed_filter, config.unicycle.steering_rate_filter,
               config.bicycle.geometry) {
  // One isotropic virtual mass (Colgate et al. §3.1, a rigid body): along its wheels the operator feels the plate's
  // own mass and inertia, so the caster asks for the same across them.
  config_.bicycle_caster.virtual_mass_kg = config_.bicycle.plate_mass_kg;
  config_.bicycle_caster.virtual_inertia_kgm2 = config_.bicycle.plate_inertia_kgm2;
  controller_.SetWallActive(false);
  Validate(config_.bicycle);
  Validate(config_.bicycle_caster);
  state_.pose.position_m = config.initial.position_m;
  state_.pose.angle_rad = config.initial.heading_rad;
  sensing_.Reset(state_);
}

const std::string& BicycleCobotDevice::name() const noexcept { return CobotName(); }

void BicycleCobotDevice::Read(Reading& out) noexcept {
  out.position_m = DofVector::Zero(3);
  out.velocity_m_per_s = DofVector::Zero(3);
  out.force_N = DofVector::Zero(3);
  out.rendered_force_N = DofVector::Zero(3);
  const CobotSensorConfig& sensors = config_.unicycle.sensors;
  out.position_m << Quantize(state_.pose.position_m.x(), sensors.position_resolution_m),
      Quantize(state_.pose.position_m.y(), sensors.position_resolution_m), state_.pose.angle_rad;
  out.velocity_m_per_s << state_.twist(0), state_.twist(1), state_.twist(2);
  const Vec2 force = MeasuredForce();
  out.force_N << force.x(), force.y(), 0.0;
  out.faults = pending_faults_;
  pending_faults_ = kFaultNone;
  out.warnings = last_control_.stability.warning ? kWarningStabilityGuard : kWarningNone;
  if (!out.position_m.allFinite() || !out.velocity_m_per_s.allFinite() || !out.force_N.allFinite()) {
    out.faults |= kFaultNonFiniteSensor;
  }
}

Vec2 BicycleCobotDevice::MeasuredForce() const noexcept {
  const double step = config_.unicycle.sensors.force_resolution_N;
  return {Quantize(operator_force_N_.x(), step), Quantize(operator_force_N_.y(), step)};
}

void BicycleCobotDevice::Write(const Command& command) noexcept {
  if (!CobotCommandUsable(command, 3)) {
    pending_faults_ |= kFaultDriver;
    SetSafe();
    return;
  }
  safe_ = false;
  locked_ = false;
  walls_.Apply(command, state_.pose.position_m, Vec2(state_.twist(0), state_.twist(1)), controller_,
               state_.pose.angle_rad);
}

void BicycleCobotDevice::Update(double period_s) noexcept {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) {
    pending_faults_ |= kFaultDriver;
    return;
  }
  const Vec2 force =
      OperatorPush(config_.op, time_s_, Vec2(state_.twist(0), state_.twist(1)), period_s, operator_integral_N_);
  operator_force_N_ = force;
  const Vec2 measured = MeasuredForce();  // the handle force sensor, as the controllers see it
  // What the controllers see (BicycleSensing): the position quantized by the position sensing, the steering angles
  // by their encoders, the steering rates and the plate's twist estimated from the steering and wheel encoders.
  const BicyclePlantState seen = sensing_.Measure(state_, period_s);
  BicyclePlantInput in;
  in.handle_force_N = force;
  if (locked_) {
    for (std::size_t i = 0; i < 2; ++i) {
      in.steering_torque_Nm[i] = -config_.bicycle_caster.k2_Nms_per_rad * seen.steer_rate_rad_per_s[i];
    }
  } else {
    // The reference point as a virtual unicycle: heading ψ_v (the wheels' mean), speed along it, its turn rate.
    const double omega = seen.twist(2);
    const double psi = seen.pose.angle_rad + MeanSteer(seen);
    WallControllerInput wall_in;
    wall_in.position_m = seen.pose.position_m;
    wall_in.steering_angle_rad = psi;
    wall_in.speed_m_per_s = Vec2(seen.twist(0), seen.twist(1)).dot(UnitAt(psi));
    wall_in.steering_rate_rad_per_s = omega + 0.5 * (seen.steer_rate_rad_per_s[0] + seen.steer_rate_rad_per_s[1]);
    wall_in.handle_force_N = measured;
    last_control_ = controller_.Step(wall_in, period_s);
    if (last_control_.mode == WallMode::kCaster) {
      const BicycleCasterOutput out =
          BicycleCasterStep(config_.bicycle_caster, config_.bicycle.geometry, seen, measured, 0.0);
      in.steering_torque_Nm = out.steering_torque_Nm;
    } else {
      // Both wheels turn at the tracker's ω_c and are pulled onto ψ_v (modulo π: a wheel may roll backwards).
      const double k2 = config_.bicycle_caster.k2_Nms_per_rad;
      const double alignment_per_s = kAlignmentFraction / controller_.config().steering_time_constant_s;
      for (std::size_t i = 0; i < 2; ++i) {
        const double error = 0.5 * WrapAngle(2.0 * (psi - seen.pose.angle_rad - seen.steer_rad[i]));
        const double rate = last_control_.commanded_rate_rad_per_s - omega + alignment_per_s * error;
        in.steering_torque_Nm[i] = k2 * (rate - seen.steer_rate_rad_per_s[i]);
      }
    }
  }
  Step(config_.bicycle, in, period_s, state_);
  sensing_.Roll(state_, period_s);
  time_s_ += period_s;
}

void BicycleCobotDevice::SetSafe() noexcept {
  safe_ = true;
  locked_ = walls_.source() < 0;  // near a fixture: keep steering against the last wall (as the unicycle)
}

}  // namespace teleop::device::cobot
