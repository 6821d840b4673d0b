#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "device/hybrid/passivity_observer.hpp"

namespace teleop::device::hybrid {

/// The three virtual walls of Kwon & Song §4 / Table 1. The wall occupies {p : (p − point)·n ≥ 0}, n the unit
/// normal pointing into the wall; depth d = max(0, (p − point)·n), inward speed v_n = v·n.
/// - kSpring (active system): F = −k·d·n, k = 150 N/mm, motors only.
/// - kSpringPoPc: the same spring through a passivity observer/controller, motors only.
/// - kHybrid (Fig. 6(a)): the nonlinear damper on the motors, F = −c·v_n³·n while penetrating and moving in
///   (c = 1.6·10⁶ N·s³/m³), and in parallel the brakes engaged to hold against the push into the wall (a brakes-only
///   request of hold_force_N), with an optional spring (hybrid_stiffness_N_per_m, Fig. 6(a)). §4: "The instant the
///   contact with the virtual wall occurs, the brakes are activated and the motors generate the damping force as a
///   function of the end-effector velocity": the damper goes to WallOutput::motor_force_N (motors only), the hold to
///   dissipative_force_N (brakes only); their forces add.
/// Every motor force is saturated to max_force_N (the actuators' limit; 100 N: the paper's damper reaches it at
/// 40 mm/s, Fig. 7). The PO/PC observer saturates at the same limit before it observes (popc.max_force_N is set from
/// max_force_N).
/// - kLinearDamper (Fig. 7(a)): the hybrid wall with a linear damper F = −c_lin·v_n·n on the motors
///   (linear_damper_Ns_per_m = 2500: 100 N at 40 mm/s, the force Fig. 7 asks above 40 mm/s), the brakes as kHybrid
///   unless the allocation has none. §4: "the unstable condition was observed in the velocity range of 20–40 mm/s
///   when the damper model with large coefficients was employed".
enum class WallKind : std::uint8_t { kSpring, kSpringPoPc, kHybrid, kLinearDamper };

struct WallConfig {
  WallKind kind = WallKind::kSpring;
  Eigen::Vector2d point_m{0.0, 0.250};
  Eigen::Vector2d normal{0.0, 1.0};
  double stiffness_N_per_m = 150.0e3;
  double damper_coefficient = 1.6e6;       ///< N per (m/s)³.
  double linear_damper_Ns_per_m = 2500.0;  ///< kLinearDamper only.
  /// kHybrid only: the spring of Fig. 6(a) ("a spring, a damper and a brake"), F = −k_h·d·n as a shared request
  /// (desired_force_N: the brakes take it where it resists the motion, the motors the rest, and the allocation's
  /// Fig. 5(b) rule releases the brakes when it pushes the handle out). 0 (default): Table 1's "damper + brake".
  double hybrid_stiffness_N_per_m = 0.0;
  double max_force_N = 100.0;
  double hold_force_N = 1000.0;  ///< Brake hold request (clamped by what the brakes can do).
  PassivityObserverConfig popc{};
  void Validate() const;  ///< teleop::Error (non-unit normal, negative gains, ...).
};

/// What the wall asks of the device this cycle.
struct WallOutput {
  Eigen::Vector2d motor_force_N{0.0, 0.0};        ///< Motors only (the hybrid wall's damper).
  Eigen::Vector2d desired_force_N{0.0, 0.0};      ///< Motors (+ brakes where dissipative), via the allocation.
  Eigen::Vector2d dissipative_force_N{0.0, 0.0};  ///< Brakes only.
  double depth_m = 0.0;
  bool in_contact = false;
};

class WallModel {
 public:
  explicit WallModel(const WallConfig& config);
  [[nodiscard]] WallOutput Step(const Eigen::Vector2d& position_m, const Eigen::Vector2d& velocity_m_per_s,
                                double period_s) noexcept;
  void Reset() noexcept {
    observer_.Reset();
    primed_ = false;
  }
  const WallConfig& config() const noexcept { return config_; }
  const PassivityObserver& observer() const noexcept { return observer_; }

 private:
  WallConfig config_;
  PassivityObserver observer_;
  Eigen::Vector2d last_position_m_{0.0, 0.0};  ///< For the observer's displacement over the period.
  bool primed_ = false;
};

[[nodiscard]] const char* ToString(WallKind kind) noexcept;
/// "spring" | "popc" | "hybrid" | "linear-damper"; false for anything else.
[[nodiscard]] bool ParseWallKind(const char* text, WallKind& kind) noexcept;

}  // namespace teleop::device::hybrid
