#pragma once

#include "device/cobot/cobot_sensors.hpp"
#include "device/cobot/constraint.hpp"
#include "device/cobot/rate_estimator.hpp"
#include "device/cobot/unicycle_plant.hpp"
#include "device/cobot/virtual_wall.hpp"

namespace teleop::device::cobot {

/// The simulated unicycle cobot rig: plant, sensors, the u and ω estimators and the virtual-wall controller, run at
/// one control period (the prototype ran at 1 kHz). Each Step() samples the sensors, runs the controller and
/// integrates the plant over the period under the held torque — the same order as the device loop.
struct UnicycleCobotConfig {
  UnicyclePlantConfig plant{};
  CobotSensorConfig sensors{};
  VirtualWallConfig controller{};
  RateEstimatorConfig speed_filter{50.0};           ///< u from the wheel encoder.
  RateEstimatorConfig steering_rate_filter{100.0};  ///< ω from the steering encoder.
  /// When true (default) controller.steering_time_constant_s is set from the plant: τ = J/(K₂ + b).
  bool derive_time_constant = true;

  /// The rig the scenarios, tests and example configs share, sized like the paper's prototype (§3.2: 1 kHz,
  /// encoder-derived u and ω, handle force sensor, xy-frame position sensing): a 10 kg cart on a 50 mm wheel,
  /// 16384-count encoders, 10 µm position resolution, steering loop τ = `tau_s`, K₁ = 1/(10 kg), ε = 0.02 m/s,
  /// lookahead 50 mm, overlay minimum radius 0.1 m, slip with a cornering stiffness of 500 N/rad, a little
  /// steering friction (b = 0.004 N·m·s/rad, compensated in the caster, not in the tracker).
  static UnicycleCobotConfig Prototype(double tau_s = 0.02);
};

/// τ = J/(K₂ + b): the closed-loop time constant of the steering-velocity loop (eq 3c).
[[nodiscard]] double SteeringTimeConstant_s(const UnicyclePlantConfig& plant, double k2_Nms_per_rad) noexcept;

/// K₂ that gives the steering loop the time constant `tau_s` on `plant` (throws teleop::Error if not reachable).
[[nodiscard]] double SteeringGainFor(const UnicyclePlantConfig& plant, double tau_s);

/// One cycle's record (true state after the step, and what the controller did).
struct CobotSample {
  Vec2 position_m = Vec2::Zero();
  double heading_rad = 0.0;
  double speed_m_per_s = 0.0;
  double steering_rate_rad_per_s = 0.0;
  Vec2 handle_force_N = Vec2::Zero();
  double lateral_force_N = 0.0;                ///< Operator force along the wheel's left normal.
  double lateral_acceleration_m_per_s2 = 0.0;  ///< u·ω.
  double steering_torque_Nm = 0.0;
  WallControllerOutput control{};
};

class UnicycleCobot {
 public:
  /// Throws teleop::Error on a bad configuration.
  UnicycleCobot(const UnicycleCobotConfig& config, const Constraint& wall, const UnicyclePlantState& initial = {});

  /// One control period under the operator force `handle_force_N` (N, world). Real-time safe.
  CobotSample Step(const Vec2& handle_force_N, double period_s) noexcept;

  /// Force applied by the operator is also what the sensor reads; for a backend that renders something else.
  VirtualWallController& controller() noexcept { return controller_; }
  const VirtualWallController& controller() const noexcept { return controller_; }
  const UnicyclePlantState& state() const noexcept { return state_; }
  const UnicycleCobotConfig& config() const noexcept { return config_; }
  /// Freezes the steering (Γ = −K₂ω, no new steering command): the fault reaction of a cobot whose steering can no
  /// longer be trusted, which keeps the wheel on its current tangent. Brake engaged too when the rig has one.
  void SetLocked(bool locked) noexcept { locked_ = locked; }
  bool locked() const noexcept { return locked_; }

 private:
  UnicycleCobotConfig config_;
  VirtualWallController controller_;
  UnicyclePlantState state_;
  RateEstimator speed_estimator_;
  RateEstimator rate_estimator_;
  bool locked_ = false;
};

}  // namespace teleop::device::cobot
