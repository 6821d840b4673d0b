// What the simulated cobot devices share: capabilities, the Command check, the scripted operator.

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "cobot_backend_private.hpp"

namespace teleop::device::cobot {

const std::string& CobotName() noexcept {
  static const std::string name = "cobot";
  return name;
}

// The scripted operator's push (N, world) for a cart moving at `velocity` (m/s, world).
Vec2 OperatorPush(const CobotOperatorScript& op, double time_s, const Vec2& velocity, double period_s,
                  double& integral_N) noexcept {
  if (!op.enabled) return Vec2::Zero();
  const bool turned = op.then_at_s > 0.0 && time_s >= op.then_at_s;
  const Vec2 direction = UnitAt((turned ? op.then_direction_deg : op.direction_deg) * (std::numbers::pi / 180.0));
  const double error = op.speed_m_per_s - velocity.norm();
  integral_N = std::clamp(integral_N + 300.0 * error * period_s, 0.0, op.max_force_N);
  const double magnitude = std::clamp(100.0 * error + integral_N, 0.5, op.max_force_N);
  return magnitude * direction;
}

Capabilities CobotCapabilities(int dof, double brake_N) {
  Capabilities c;
  c.dof = dof;
  c.rendering = Rendering::kSteeredConstraints;
  c.max_force_N = DofVector::Zero(dof);
  c.has_brake = brake_N > 0.0;
  c.max_brake_force_N = DofVector::Constant(dof, brake_N);
  c.measures_velocity = true;
  c.measures_force = true;
  return c;
}

bool CobotCommandUsable(const Command& command, int dof) noexcept {
  if (command.force_N.size() != dof || !command.force_N.allFinite()) return false;
  if (command.fixture_force_N.size() != 0 &&
      (command.fixture_force_N.size() != dof || !command.fixture_force_N.allFinite())) {
    return false;
  }
  if (command.constraint_count < 0 || command.constraint_count > kMaxConstraints) return false;
  for (int i = 0; i < command.constraint_count; ++i) {
    const device::Constraint& c = command.constraints[static_cast<std::size_t>(i)];
    if (c.normal.size() != dof || !c.normal.allFinite() || !std::isfinite(c.offset_m) ||
        !std::isfinite(c.penetration_m)) {
      return false;
    }
  }
  return true;
}

}  // namespace teleop::device::cobot
