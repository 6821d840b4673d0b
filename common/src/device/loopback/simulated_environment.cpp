#include <string>

#include "teleop/device/loopback.hpp"
#include "validate.hpp"

namespace teleop::device {

using loopback_detail::Fail;
using loopback_detail::RequireFinite;
using loopback_detail::RequireNonNegative;

SimulatedEnvironment::SimulatedEnvironment(const SimulatedEnvironmentConfig& env, int dof) : config_(env) {
  if (env.kind == SimulatedEnvironmentConfig::Kind::kFreeSpace) return;
  if (env.kind != SimulatedEnvironmentConfig::Kind::kWall) Fail("environment.kind is not free space or wall");
  if (env.axis < 0 || env.axis >= dof) {
    Fail("environment.axis " + std::to_string(env.axis) + " is out of range for dof " + std::to_string(dof));
  }
  RequireFinite(env.position_m, "environment.position_m");
  RequireNonNegative(env.stiffness_N_per_m, "environment.stiffness_N_per_m");
  RequireNonNegative(env.damping_Ns_per_m, "environment.damping_Ns_per_m");
}

double SimulatedEnvironment::Push_N(double position_m, double velocity_m_per_s) const noexcept {
  const double depth_m = position_m - config_.position_m;
  if (depth_m <= 0.0) return 0.0;
  const double push_N = config_.stiffness_N_per_m * depth_m + config_.damping_Ns_per_m * velocity_m_per_s;
  return push_N > 0.0 ? push_N : 0.0;
}

}  // namespace teleop::device
