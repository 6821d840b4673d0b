#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace teleop::device::hybrid {

/// Frictional surface of Kwon & Song §5 (Fig. 10). The surface occupies {p : (p − point)·n ≥ 0}; the motors render
/// its normal reaction as a spring–damper that only pushes (stiffness_N_per_m, damping_Ns_per_m; the paper gives no
/// values: 10 N/mm and 100 N·s/m keep it stable under the 7 ms motor lag); the friction force along the tangent t (n
/// rotated by −90°) is μ·F_N with F_N = F_h·n, the operator's push into the surface measured by the handle force sensor
/// (μ = static_coefficient at rest, kinetic_coefficient sliding, rest below rest_speed_m_per_s).
/// - kMotor: the motors render the friction too, clipped to the operator's tangential force |F_h·t| so it can never
///   drive the handle (§5: "restricted to less than or equal to F_hx").
/// - kBrake: the brakes render it (a dissipative request through the allocation): no clipping is needed, a brake
///   cannot drive motion.
enum class FrictionDisplay : std::uint8_t { kMotor, kBrake };

struct FrictionConfig {
  FrictionDisplay display = FrictionDisplay::kBrake;
  Eigen::Vector2d point_m{0.0, 0.250};
  Eigen::Vector2d normal{0.0, 1.0};
  double stiffness_N_per_m = 10.0e3;
  double damping_Ns_per_m = 100.0;
  double max_normal_force_N = 100.0;
  double static_coefficient = 0.5;
  double kinetic_coefficient = 0.35;
  double rest_speed_m_per_s = 0.005;
  void Validate() const;
};

struct FrictionOutput {
  Eigen::Vector2d desired_force_N{0.0, 0.0};      ///< Normal reaction (+ friction when displayed by motors).
  Eigen::Vector2d dissipative_force_N{0.0, 0.0};  ///< Friction when displayed by brakes.
  double friction_target_N = 0.0;                 ///< μ·F_N, the friction the surface should show (≥ 0).
  double normal_force_N = 0.0;                    ///< F_N from the sensor (≥ 0).
  bool in_contact = false;
};

/// Stateless per cycle; real-time safe.
[[nodiscard]] FrictionOutput FrictionStep(const FrictionConfig& config, const Eigen::Vector2d& position_m,
                                          const Eigen::Vector2d& velocity_m_per_s,
                                          const Eigen::Vector2d& measured_hand_force_N) noexcept;

[[nodiscard]] const char* ToString(FrictionDisplay display) noexcept;
[[nodiscard]] bool ParseFrictionDisplay(const char* text, FrictionDisplay& display) noexcept;

}  // namespace teleop::device::hybrid
