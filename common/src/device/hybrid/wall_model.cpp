#include "device/hybrid/wall_model.hpp"

#include <cmath>
#include <cstring>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {
namespace {

Eigen::Vector2d Saturate(const Eigen::Vector2d& f, double max_N) noexcept {
  const double n = f.norm();
  return n > max_N ? Eigen::Vector2d(f * (max_N / n)) : f;
}

}  // namespace

void WallConfig::Validate() const {
  if (!point_m.allFinite() || !normal.allFinite() || std::abs(normal.norm() - 1.0) > 1e-6) {
    throw Error("hybrid wall: point_m must be finite and normal a unit vector");
  }
  if (!(std::isfinite(stiffness_N_per_m) && stiffness_N_per_m >= 0.0) ||
      !(std::isfinite(damper_coefficient) && damper_coefficient >= 0.0) ||
      !(std::isfinite(linear_damper_Ns_per_m) && linear_damper_Ns_per_m >= 0.0) ||
      !(std::isfinite(hybrid_stiffness_N_per_m) && hybrid_stiffness_N_per_m >= 0.0) ||
      !(std::isfinite(max_force_N) && max_force_N > 0.0) || !(std::isfinite(hold_force_N) && hold_force_N >= 0.0)) {
    throw Error("hybrid wall: stiffness, damper coefficient and hold force must be >= 0, max_force_N > 0");
  }
  popc.Validate();
}

namespace {

PassivityObserverConfig SaturatedAt(PassivityObserverConfig popc, double max_force_N) {
  popc.max_force_N = max_force_N;
  return popc;
}

}  // namespace

WallModel::WallModel(const WallConfig& config)
    : config_(config), observer_(SaturatedAt(config.popc, config.max_force_N)) {
  config_.Validate();
  config_.popc.max_force_N = config_.max_force_N;
}

WallOutput WallModel::Step(const Eigen::Vector2d& position_m, const Eigen::Vector2d& velocity_m_per_s,
                           double period_s) noexcept {
  WallOutput out;
  if (!position_m.allFinite() || !velocity_m_per_s.allFinite()) {
    return out;
  }
  const Eigen::Vector2d& n = config_.normal;
  const double signed_depth = (position_m - config_.point_m).dot(n);
  out.in_contact = signed_depth > 0.0;
  out.depth_m = out.in_contact ? signed_depth : 0.0;
  const double v_in = velocity_m_per_s.dot(n);
  const Eigen::Vector2d previous = last_position_m_;
  last_position_m_ = position_m;
  const bool primed = primed_;
  primed_ = true;
  switch (config_.kind) {
    case WallKind::kSpring:
      out.desired_force_N = Saturate(-config_.stiffness_N_per_m * out.depth_m * n, config_.max_force_N);
      break;
    case WallKind::kSpringPoPc: {
      const Eigen::Vector2d spring = -config_.stiffness_N_per_m * out.depth_m * n;
      const Eigen::Vector2d moved = primed ? Eigen::Vector2d(position_m - previous) : Eigen::Vector2d::Zero();
      out.desired_force_N = Saturate(observer_.Step(spring, moved, velocity_m_per_s, period_s), config_.max_force_N);
      break;
    }
    case WallKind::kHybrid:
      if (out.in_contact) {
        if (v_in > 0.0) {
          out.motor_force_N = Saturate(-config_.damper_coefficient * v_in * v_in * v_in * n, config_.max_force_N);
        }
        out.desired_force_N = Saturate(-config_.hybrid_stiffness_N_per_m * out.depth_m * n, config_.max_force_N);
        out.dissipative_force_N = -config_.hold_force_N * n;
      }
      break;
    case WallKind::kLinearDamper:
      if (out.in_contact) {
        if (v_in > 0.0) {
          out.motor_force_N = Saturate(-config_.linear_damper_Ns_per_m * v_in * n, config_.max_force_N);
        }
        out.dissipative_force_N = -config_.hold_force_N * n;
      }
      break;
  }
  return out;
}

const char* ToString(WallKind kind) noexcept {
  switch (kind) {
    case WallKind::kSpring:
      return "spring";
    case WallKind::kSpringPoPc:
      return "popc";
    case WallKind::kHybrid:
      return "hybrid";
    case WallKind::kLinearDamper:
      return "linear-damper";
  }
  return "?";
}

bool ParseWallKind(const char* text, WallKind& kind) noexcept {
  if (text == nullptr) {
    return false;
  }
  for (WallKind k : {WallKind::kSpring, WallKind::kSpringPoPc, WallKind::kHybrid, WallKind::kLinearDamper}) {
    if (std::strcmp(text, ToString(k)) == 0) {
      kind = k;
      return true;
    }
  }
  return false;
}

}  // namespace teleop::device::hybrid
