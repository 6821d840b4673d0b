#pragma once

#include <cstdint>

namespace teleop::device {

/// The simulated environment on the slave: free space, or a wall x ≥ position_m on one axis with stiffness and
/// damping (a spring–damper that only pushes).
///
/// Sign (docs/frames.md): the wall's force ON the device is -max(0, k·(x - p) + b·ẋ) along the axis while x > p,
/// else 0. The force sensor reports the reaction, F_e of eq. 4, the force the slave exerts ON the environment:
/// F_e = +max(0, k·(x - p) + b·ẋ) ≥ 0 (positive when the slave pushes along +x).
struct SimulatedEnvironmentConfig {
  enum class Kind : std::uint8_t { kFreeSpace, kWall };
  Kind kind = Kind::kFreeSpace;
  int axis = 0;
  double position_m = 0.0;  ///< Wall surface along `axis`; the wall occupies x > position_m.
  double stiffness_N_per_m = 0.0;
  double damping_Ns_per_m = 0.0;
};

/// A SimulatedEnvironmentConfig, validated, with the wall's contact law.
class SimulatedEnvironment {
 public:
  /// Free space.
  SimulatedEnvironment() = default;
  /// Validates for `dof`; throws teleop::Error "loopback plant: environment.…" naming the field.
  SimulatedEnvironment(const SimulatedEnvironmentConfig& config, int dof);

  /// True when the wall acts on `axis`.
  bool OnAxis(int axis) const noexcept {
    return config_.kind == SimulatedEnvironmentConfig::Kind::kWall && config_.axis == axis;
  }
  /// The magnitude the wall pushes back with at (x, ẋ) on its axis, max(0, k·(x - p) + b·ẋ) inside, 0 outside (N).
  /// This is F_e.
  double Push_N(double position_m, double velocity_m_per_s) const noexcept;
  const SimulatedEnvironmentConfig& config() const noexcept { return config_; }

 private:
  SimulatedEnvironmentConfig config_{};
};

}  // namespace teleop::device
