#pragma once

#include <Eigen/Core>
#include <vector>

#include "device/hybrid/friction_display.hpp"
#include "device/hybrid/hybrid_rig.hpp"
#include "device/hybrid/motor_brake_allocation.hpp"
#include "device/hybrid/operator_hand.hpp"
#include "device/hybrid/wall_model.hpp"

namespace teleop::device::hybrid {

/// One control cycle of a scenario run (base frame; "normal" components along the wall/surface normal n, positive
/// into the wall; "tangent" along t).
struct ScenarioSample {
  double time_s = 0.0;
  Eigen::Vector2d position_m{0.0, 0.0};
  Eigen::Vector2d velocity_m_per_s{0.0, 0.0};
  double depth_m = 0.0;              ///< Signed penetration (p − point)·n; < 0 outside.
  double rendered_normal_N = 0.0;    ///< Actuators' force on the handle, −n component (the wall's push-back).
  double desired_normal_N = 0.0;     ///< What the environment asked for (−n component of desired + dissipative).
  double motor_normal_N = 0.0;       ///< Motor part of it.
  double brake_normal_N = 0.0;       ///< Brake part of it.
  double hand_normal_N = 0.0;        ///< Sensor: the operator's push along n.
  double hand_tangent_N = 0.0;       ///< Sensor: the operator's push along t.
  double rendered_tangent_N = 0.0;   ///< Actuators' force along −t (friction shown), N.
  double friction_target_N = 0.0;    ///< μ·F_N (friction scenario).
  double brake_capacity_1_Nm = 0.0;  ///< Joint side.
  double brake_capacity_2_Nm = 0.0;
};

/// The numbers the paper reads off Figs. 8, 9, 11, 12 (definitions in docs/hybrid.md).
struct ContactMetrics {
  int bounces = 0;                     ///< Separations: in contact, then more than 0.1 mm outside the surface.
  int big_bounces = 0;                 ///< Separations that leave the surface by more than 1 mm.
  double largest_bounce_mm = 0.0;      ///< Highest excursion outside the surface after a contact.
  double transient_s = 0.0;            ///< First contact → last time the depth is outside final ± max(0.5 mm, 10 %).
  double steady_state_error_mm = 0.0;  ///< Mean depth over the last 0.1 s.
  double peak_force_N = 0.0;           ///< Largest push-back of the actuators on the handle.
  double peak_hand_force_N = 0.0;
  double max_depth_mm = 0.0;
  double contact_speed_mm_s = 0.0;    ///< Inward speed at first contact (measured).
  double commanded_speed_mm_s = 0.0;  ///< The hand's intended approach speed.
  double nominal_speed_mm_s = 0.0;    ///< The paper's speed the run stands for (250 or 1500).
  int velocity_reversals = 0;         ///< Sign changes of the inward velocity in contact (damper chatter, Fig. 7(a)).
  double contact_time_s = -1.0;       ///< −1: never touched.
  double brake_energy_J = 0.0;        ///< Work of the brakes on the linkage (≤ 0).
  double motor_energy_J = 0.0;
  // Friction scenario only.
  double friction_rms_error_N = 0.0;      ///< RMS of (shown friction − μ·F_N) while sliding.
  double friction_positive_work_J = 0.0;  ///< Work the shown friction did on the handle where it was positive.
  double normal_force_std_N = 0.0;        ///< Spread of the operator's normal push while sliding.
  double slide_mm = 0.0;                  ///< Tangential travel.
};

struct ScenarioResult {
  std::vector<ScenarioSample> samples;
  ContactMetrics metrics;
};

struct WallScenarioConfig {
  HybridRigConfig rig{};
  AllocationConfig allocation{};
  WallConfig wall{};
  OperatorHandConfig hand{};
  double hand_mass_kg = 0.5;  ///< Added to the handle mass.
  double period_s = 0.001;
  double duration_s = 0.8;
  double commanded_speed_m_per_s = 0.0;  ///< The nominal speed (hand.speed_m_per_s may differ: calibrated).
};

/// The §4 experiment: the hand pushes the handle into the wall at `speed_m_per_s` with up to `hand_force_N`.
/// Defaults: wall at y = 250 mm (normal +y), start at x = 0, y = 200 mm (weak) or 130 mm (strong, to reach the speed);
/// weak (250 mm/s, 25 N) or strong (1500 mm/s, 80 N) contact as in Figs. 8 and 9.
[[nodiscard]] WallScenarioConfig PaperWallScenario(WallKind kind, double speed_m_per_s);
/// Sets c.hand.speed_m_per_s so that the speed measured at contact is contact_speed_m_per_s (within 0.1 %).
void CalibrateContactSpeed(WallScenarioConfig& c, double contact_speed_m_per_s);
/// PaperWallScenario with the hand's intended speed chosen so that the speed measured at contact is
/// contact_speed_m_per_s (the arm overshoots: 1500 mm/s intended gives about 1680 mm/s at contact).
[[nodiscard]] WallScenarioConfig PaperWallScenarioAtContactSpeed(WallKind kind, double contact_speed_m_per_s);
[[nodiscard]] ScenarioResult RunWallScenario(const WallScenarioConfig& config);

/// Fig. 7(a): the hand meets a damper wall (kHybrid: cubic, kLinearDamper: linear) 5 mm ahead at a slow speed
/// (20–40 mm/s, the range where §4 saw the linear damper unstable), with up to 25 N, for 1 s; brakes as asked.
[[nodiscard]] WallScenarioConfig PaperDamperScenario(WallKind kind, double speed_m_per_s, bool brakes);

/// Fig. 5(b) on the wall: the weak contact (250 mm/s, 25 N) with the hybrid wall and its spring (Fig. 6(a),
/// hybrid_stiffness_N_per_m); the hand lets go at 0.4 s and the run lasts 0.8 s. Held, the brakes resist the hand's
/// push; let go, the spring's reaction is larger than the hand's force, the allocation releases the brakes and the
/// motors push the handle back out (with stiffness 0 nothing does).
[[nodiscard]] WallScenarioConfig PaperReleaseScenario(double hybrid_stiffness_N_per_m);

/// The scenario `hybrid-wall --model M --speed-mm-s V` runs: the damper wall met 5 mm ahead (PaperDamperScenario,
/// brakes on; `--no-brakes` turns them off) for linear-damper, whose figure is Fig. 7(a); the §4 contact
/// (PaperWallScenario) for the others.
[[nodiscard]] WallScenarioConfig ScenarioForModel(WallKind kind, double speed_m_per_s);

struct FrictionScenarioConfig {
  HybridRigConfig rig{};
  AllocationConfig allocation{};
  FrictionConfig friction{};
  OperatorHandConfig hand{};
  double hand_mass_kg = 0.5;
  double period_s = 0.001;
  double duration_s = 1.6;
};

/// The §5 experiment: press onto the surface with `normal_force_N`, then drag along it (Figs. 11, 12).
[[nodiscard]] FrictionScenarioConfig PaperFrictionScenario(FrictionDisplay display, double normal_force_N);
[[nodiscard]] ScenarioResult RunFrictionScenario(const FrictionScenarioConfig& config);

}  // namespace teleop::device::hybrid
