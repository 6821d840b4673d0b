// The simulated unicycle cobot behind the Device interface (UnicycleCobotDevice, cobot_backend.hpp).

#include <cmath>

#include "cobot_backend_private.hpp"

namespace teleop::device::cobot {

UnicycleCobotDevice::UnicycleCobotDevice(const CobotBackendConfig& config)
    : config_(config),
      capabilities_(CobotCapabilities(2, config.unicycle.plant.brake_max_force_N)),
      rig_(config.unicycle, Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true), config.initial),
      walls_(config.contact_force_threshold_N) {
  rig_.controller().SetWallActive(false);
  last_.position_m = config.initial.position_m;
  last_.heading_rad = config.initial.heading_rad;
}

const std::string& UnicycleCobotDevice::name() const noexcept { return CobotName(); }

void UnicycleCobotDevice::Read(Reading& out) noexcept {
  const UnicyclePlantState& s = rig_.state();
  const CobotMeasurement m =
      Measure(config_.unicycle.sensors, s.position_m, s.heading_rad, s.wheel_travel_m, operator_force_N_);
  const Vec2 velocity = s.speed_m_per_s * UnitAt(s.heading_rad);
  const double floor_N = FloorLateralForce_N(config_.unicycle.plant, s, operator_force_N_);
  const Vec2 floor = floor_N * LeftNormal(UnitAt(s.heading_rad));
  out.position_m = DofVector::Zero(2);
  out.velocity_m_per_s = DofVector::Zero(2);
  out.force_N = DofVector::Zero(2);
  out.rendered_force_N = DofVector::Zero(2);
  out.position_m << m.position_m.x(), m.position_m.y();
  out.velocity_m_per_s << velocity.x(), velocity.y();
  out.force_N << m.handle_force_N.x(), m.handle_force_N.y();
  out.rendered_force_N << floor.x(), floor.y();
  out.faults = pending_faults_;
  pending_faults_ = kFaultNone;
  out.warnings = last_.control.stability.warning ? kWarningStabilityGuard : kWarningNone;
  if (!out.position_m.allFinite() || !out.velocity_m_per_s.allFinite() || !out.force_N.allFinite()) {
    out.faults |= kFaultNonFiniteSensor;
  }
}

void UnicycleCobotDevice::Write(const Command& command) noexcept {
  if (!CobotCommandUsable(command, 2)) {
    pending_faults_ |= kFaultDriver;
    SetSafe();
    return;
  }
  safe_ = false;
  rig_.SetLocked(false);
  const UnicyclePlantState& s = rig_.state();
  walls_.Apply(command, s.position_m, s.speed_m_per_s * UnitAt(s.heading_rad), rig_.controller());
}

void UnicycleCobotDevice::Update(double period_s) noexcept {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) {
    pending_faults_ |= kFaultDriver;
    return;
  }
  const UnicyclePlantState& s = rig_.state();
  operator_force_N_ =
      OperatorPush(config_.op, time_s_, s.speed_m_per_s * UnitAt(s.heading_rad), period_s, operator_integral_N_);
  last_ = rig_.Step(operator_force_N_, period_s);
  time_s_ += period_s;
}

void UnicycleCobotDevice::SetSafe() noexcept {
  safe_ = true;
  // Near a fixture (a wall is set) the safe state keeps steering against the last wall: the wheel turns to its
  // tangent (overlay, tracking) and a push into it is refused, as in normal operation; locking the steering there
  // would let a wheel aimed at the wall roll through it. With no wall the steering is locked (and braked).
  rig_.SetLocked(walls_.source() < 0);
}

}  // namespace teleop::device::cobot
