#include "hybrid/contact_scenarios.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "teleop/error.hpp"

namespace teleop::device::hybrid {
namespace {

constexpr double kBounceGap_m = 0.1e-3;
constexpr double kBigBounce_m = 1e-3;  ///< A "big" bounce (Fig. 9(b)'s) leaves the surface by more than 1 mm.
constexpr double kSettleBand_m = 0.5e-3;
constexpr double kFinalWindow_s = 0.1;
constexpr double kReversalStep_m_per_s = 2e-3;  ///< A reversal counts when the velocity jumps by more than 2 mm/s.

struct Demand {
  Eigen::Vector2d motor_N{0.0, 0.0};
  Eigen::Vector2d desired_N{0.0, 0.0};
  Eigen::Vector2d dissipative_N{0.0, 0.0};
  bool brakes_for_desired = true;
  double friction_target_N = 0.0;
};

/// The shared loop: hand → sensor → environment → allocation → rig, at period_s.
template <typename Environment>
ScenarioResult Run(HybridRigConfig rig_config, const AllocationConfig& allocation,
                   const OperatorHandConfig& hand_config, double hand_mass_kg, const Eigen::Vector2d& normal,
                   double period_s, double duration_s, Environment&& environment) {
  if (!(period_s > 0.0) || !(duration_s > 0.0) || !(hand_mass_kg >= 0.0)) {
    throw Error("hybrid scenario: period, duration must be > 0 and hand mass >= 0");
  }
  rig_config.handle_mass_kg += hand_mass_kg;
  rig_config.initial_position_m = hand_config.start_m;
  HybridRig rig(rig_config);
  MotorBrakeAllocator allocator(allocation);
  const OperatorHand hand(hand_config);
  // What the controller sees: quantized encoders with a velocity estimate, the force sensor's noise and bandwidth.
  JointEncoders encoders(rig_config.encoders);
  encoders.Reset(rig.state().joint_rad);
  ForceSensorDynamics sensor(rig_config.force_sensor_dynamics);
  const Eigen::Vector2d tangent{normal.y(), -normal.x()};
  ScenarioResult result;
  const int steps = static_cast<int>(std::lround(duration_s / period_s));
  result.samples.reserve(static_cast<std::size_t>(steps));
  for (int k = 0; k < steps; ++k) {
    const double t = k * period_s;
    const RigState& s = rig.state();
    encoders.Sample(s.joint_rad, s.joint_velocity_rad_per_s, period_s);
    Eigen::Matrix2d jac;
    Eigen::Vector2d sensed_p;
    if (s.singular || !rig.kinematics().Jacobian(encoders.joint_rad(), jac) ||
        !rig.kinematics().Forward(encoders.joint_rad(), sensed_p)) {
      throw Error("hybrid scenario: the linkage reached a singular configuration");
    }
    const Eigen::Vector2d sensed_v = jac * encoders.joint_velocity_rad_per_s();
    const Eigen::Vector2d hand_force = hand.Force(t, s.position_m, s.velocity_m_per_s);
    const Eigen::Vector2d measured = sensor.Filter(MeasureHandleForce(rig_config.force_sensor, hand_force), period_s);
    const Demand demand = environment(sensed_p, sensed_v, measured);
    AllocationInput in;
    in.jacobian_m_per_rad = jac;
    in.joint_velocity_rad_per_s = encoders.joint_velocity_rad_per_s();
    in.hand_force_N = measured;
    in.motor_force_N = demand.motor_N;
    in.desired_force_N = demand.desired_N;
    in.dissipative_force_N = demand.dissipative_N;
    in.brakes_for_desired = demand.brakes_for_desired;
    const AllocationOutput out = allocator.Step(in, period_s);
    rig.Step(out.motor_joint_Nm, out.brake_shaft_Nm, hand_force, period_s);
    const RigState& after = rig.state();
    Eigen::Matrix2d jac_after;
    if (!rig.kinematics().Jacobian(after.joint_rad, jac_after)) {
      throw Error("hybrid scenario: the linkage reached a singular configuration");
    }
    const Eigen::Matrix2d jt_inv = jac_after.transpose().inverse();
    ScenarioSample x;
    x.time_s = t + period_s;
    x.position_m = after.position_m;
    x.velocity_m_per_s = after.velocity_m_per_s;
    x.rendered_normal_N = -after.rendered_force_N.dot(normal);
    x.desired_normal_N = -(demand.motor_N + demand.desired_N).dot(normal);
    x.motor_normal_N = -(jt_inv * after.motor_joint_Nm).dot(normal);
    x.brake_normal_N = -(jt_inv * after.brake_joint_Nm).dot(normal);
    x.hand_normal_N = measured.dot(normal);
    x.hand_tangent_N = measured.dot(tangent);
    x.rendered_tangent_N = -after.rendered_force_N.dot(tangent);
    x.friction_target_N = demand.friction_target_N;
    x.brake_capacity_1_Nm = after.brake_capacity_joint_Nm.x();
    x.brake_capacity_2_Nm = after.brake_capacity_joint_Nm.y();
    result.samples.push_back(x);
  }
  result.metrics.brake_energy_J = rig.state().brake_energy_J;
  result.metrics.motor_energy_J = rig.state().motor_energy_J;
  return result;
}

void ContactMetricsFrom(ScenarioResult& r, const Eigen::Vector2d& point, const Eigen::Vector2d& normal) {
  ContactMetrics& m = r.metrics;
  auto& samples = r.samples;
  for (auto& s : samples) {
    s.depth_m = (s.position_m - point).dot(normal);
  }
  if (samples.empty()) {
    return;
  }
  bool in_contact = false;
  bool bouncing = false;  // separated after a contact, height not yet booked
  double height = 0.0;
  const auto book = [&] {
    if (!bouncing) return;
    m.largest_bounce_mm = std::max(m.largest_bounce_mm, 1e3 * height);
    if (height > kBigBounce_m) ++m.big_bounces;
    bouncing = false;
  };
  std::size_t first = samples.size();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const ScenarioSample& s = samples[i];
    if (bouncing) height = std::max(height, -s.depth_m);
    if (bouncing && s.depth_m > 0.0) book();
    m.peak_force_N = std::max(m.peak_force_N, s.rendered_normal_N);
    m.peak_hand_force_N = std::max(m.peak_hand_force_N, std::abs(s.hand_normal_N));
    m.max_depth_mm = std::max(m.max_depth_mm, 1e3 * s.depth_m);
    if (!in_contact && s.depth_m > 0.0) {
      in_contact = true;
      if (first == samples.size()) {
        first = i;
        m.contact_time_s = s.time_s;
        m.contact_speed_mm_s = 1e3 * s.velocity_m_per_s.dot(normal);
      }
    } else if (in_contact && s.depth_m < -kBounceGap_m) {
      in_contact = false;
      ++m.bounces;
      bouncing = true;
      height = -s.depth_m;
    }
  }
  book();
  // Velocity reversals while in contact after the first contact: a chattering damper flips the inward velocity.
  for (std::size_t i = first + 1; i < samples.size(); ++i) {
    const double a = samples[i - 1].velocity_m_per_s.dot(normal);
    const double b = samples[i].velocity_m_per_s.dot(normal);
    if (samples[i].depth_m > 0.0 && a * b < 0.0 && std::abs(a - b) > kReversalStep_m_per_s) ++m.velocity_reversals;
  }
  const double t_end = samples.back().time_s;
  double sum = 0.0;
  int count = 0;
  for (const auto& s : samples) {
    if (s.time_s > t_end - kFinalWindow_s) {
      sum += s.depth_m;
      ++count;
    }
  }
  const double final_depth = count > 0 ? sum / count : 0.0;
  m.steady_state_error_mm = 1e3 * final_depth;
  if (first < samples.size()) {
    const double band = std::max(kSettleBand_m, 0.1 * std::abs(final_depth));
    double last_out = samples[first].time_s;
    for (std::size_t i = first; i < samples.size(); ++i) {
      if (std::abs(samples[i].depth_m - final_depth) > band) {
        last_out = samples[i].time_s;
      }
    }
    m.transient_s = last_out - samples[first].time_s;
  }
}

}  // namespace

WallScenarioConfig PaperWallScenario(WallKind kind, double speed_m_per_s) {
  WallScenarioConfig c;
  c.wall.kind = kind;
  c.wall.point_m = {0.0, 0.250};
  c.wall.normal = {0.0, 1.0};
  c.allocation.motor = c.rig.motor;
  c.allocation.brake = AllocationBrakeModel(c.rig.brake, c.allocation.brake_model_mismatch);
  c.allocation.use_brakes = kind == WallKind::kHybrid || kind == WallKind::kLinearDamper;
  c.wall.popc.actuator_time_constant_s = c.rig.motor.time_constant_s;  // the observer's actuator model: the motor's
  c.commanded_speed_m_per_s = speed_m_per_s;                           // the nominal speed the scenario stands for
  const bool strong = speed_m_per_s > 1.0;
  c.hand.start_m = {0.0, strong ? 0.130 : 0.200};
  c.hand.direction = {0.0, 1.0};
  c.hand.speed_m_per_s = speed_m_per_s;
  c.hand.max_force_N = strong ? 80.0 : 25.0;
  // The intention ends past the surface by the stretch the hand's arm needs for its force, plus 30 mm.
  c.hand.travel_m = (c.wall.point_m.y() - c.hand.start_m.y()) + c.hand.max_force_N / c.hand.stiffness_N_per_m + 0.030;
  return c;
}

ScenarioResult RunWallScenario(const WallScenarioConfig& config) {
  WallModel wall(config.wall);
  const bool hybrid = config.wall.kind == WallKind::kHybrid || config.wall.kind == WallKind::kLinearDamper;
  ScenarioResult r =
      Run(config.rig, config.allocation, config.hand, config.hand_mass_kg, config.wall.normal, config.period_s,
          config.duration_s, [&](const Eigen::Vector2d& p, const Eigen::Vector2d& v, const Eigen::Vector2d& /*hand*/) {
            const WallOutput w = wall.Step(p, v, config.period_s);
            Demand d;
            d.motor_N = w.motor_force_N;
            d.desired_N = w.desired_force_N;
            d.dissipative_N = w.dissipative_force_N;
            d.brakes_for_desired = hybrid;
            return d;
          });
  ContactMetricsFrom(r, config.wall.point_m, config.wall.normal);
  r.metrics.commanded_speed_mm_s = 1e3 * config.hand.speed_m_per_s;
  r.metrics.nominal_speed_mm_s = 1e3 * config.commanded_speed_m_per_s;
  return r;
}

void CalibrateContactSpeed(WallScenarioConfig& c, double contact_speed_m_per_s) {
  if (!(contact_speed_m_per_s > 0.0)) throw Error("hybrid scenario: the contact speed must be > 0");
  // The hand's arm overshoots its intended speed before contact; find the intended speed whose measured contact
  // speed is the nominal one (secant on the run up to contact, which the wall does not influence).
  const double distance = (c.wall.point_m - c.hand.start_m).dot(c.wall.normal);
  const auto error = [&](double commanded) {
    WallScenarioConfig probe = c;
    probe.hand.speed_m_per_s = commanded;
    probe.duration_s = std::min(c.duration_s, distance / commanded + 0.05);
    const ContactMetrics m = RunWallScenario(probe).metrics;
    return (m.contact_time_s < 0.0 ? 0.0 : 1e-3 * m.contact_speed_mm_s) - contact_speed_m_per_s;
  };
  double x0 = contact_speed_m_per_s;
  double f0 = error(x0);
  double x1 = contact_speed_m_per_s * contact_speed_m_per_s / std::max(1e-3, f0 + contact_speed_m_per_s);
  for (int i = 0; i < 8 && std::abs(f0) > 1e-3 * contact_speed_m_per_s; ++i) {
    const double f1 = error(x1);
    if (std::abs(f1 - f0) < 1e-12) break;
    const double x2 = std::clamp(x1 - f1 * (x1 - x0) / (f1 - f0), 0.2 * contact_speed_m_per_s, contact_speed_m_per_s);
    x0 = x1;
    f0 = f1;
    x1 = x2;
  }
  c.hand.speed_m_per_s = x0;
}

WallScenarioConfig PaperWallScenarioAtContactSpeed(WallKind kind, double contact_speed_m_per_s) {
  WallScenarioConfig c = PaperWallScenario(kind, contact_speed_m_per_s);
  CalibrateContactSpeed(c, contact_speed_m_per_s);
  return c;
}

WallScenarioConfig PaperDamperScenario(WallKind kind, double speed_m_per_s, bool brakes) {
  WallScenarioConfig c = PaperWallScenario(kind, speed_m_per_s);
  c.hand.start_m = {0.0, c.wall.point_m.y() - 0.005};
  c.hand.travel_m = 0.005 + c.hand.max_force_N / c.hand.stiffness_N_per_m + 0.030;
  c.allocation.use_brakes = brakes;
  c.duration_s = 1.0;
  return c;
}

WallScenarioConfig PaperReleaseScenario(double hybrid_stiffness_N_per_m) {
  WallScenarioConfig c = PaperWallScenario(WallKind::kHybrid, 0.25);
  c.wall.hybrid_stiffness_N_per_m = hybrid_stiffness_N_per_m;
  c.hand.release_s = 0.4;
  return c;
}

WallScenarioConfig ScenarioForModel(WallKind kind, double speed_m_per_s) {
  return kind == WallKind::kLinearDamper ? PaperDamperScenario(kind, speed_m_per_s, true)
                                         : PaperWallScenario(kind, speed_m_per_s);
}

FrictionScenarioConfig PaperFrictionScenario(FrictionDisplay display, double normal_force_N) {
  FrictionScenarioConfig c;
  c.friction.display = display;
  c.friction.point_m = {0.0, 0.250};
  c.friction.normal = {0.0, 1.0};
  c.allocation.motor = c.rig.motor;
  c.allocation.brake = AllocationBrakeModel(c.rig.brake, c.allocation.brake_model_mismatch);
  c.allocation.use_brakes = display == FrictionDisplay::kBrake;
  c.hand.start_m = {-0.080, 0.240};
  c.hand.direction = {0.0, 1.0};
  c.hand.speed_m_per_s = 0.1;
  c.hand.max_force_N = normal_force_N;
  c.hand.travel_m = 0.010 + normal_force_N / c.hand.stiffness_N_per_m + 0.010;
  c.hand.side_direction = {1.0, 0.0};
  c.hand.side_speed_m_per_s = 0.1;
  c.hand.side_start_s = 0.4;
  c.hand.side_travel_m = 0.120;
  c.hand.side_max_force_N = 40.0;
  return c;
}

ScenarioResult RunFrictionScenario(const FrictionScenarioConfig& config) {
  const Eigen::Vector2d n = config.friction.normal;
  const Eigen::Vector2d t{n.y(), -n.x()};
  ScenarioResult r =
      Run(config.rig, config.allocation, config.hand, config.hand_mass_kg, n, config.period_s, config.duration_s,
          [&](const Eigen::Vector2d& p, const Eigen::Vector2d& v, const Eigen::Vector2d& hand) {
            const FrictionOutput f = FrictionStep(config.friction, p, v, hand);
            Demand d;
            d.desired_N = f.desired_force_N;
            d.dissipative_N = f.dissipative_force_N;
            d.brakes_for_desired = false;  // §5: the normal reaction by the motors.
            d.friction_target_N = f.friction_target_N;
            return d;
          });
  ContactMetricsFrom(r, config.friction.point_m, n);
  ContactMetrics& m = r.metrics;
  double err2 = 0.0;
  double sum_n = 0.0;
  double sum_n2 = 0.0;
  int sliding = 0;
  for (std::size_t i = 1; i < r.samples.size(); ++i) {
    const ScenarioSample& s = r.samples[i];
    const double v_t = s.velocity_m_per_s.dot(t);
    const double dt = s.time_s - r.samples[i - 1].time_s;
    // Shown friction acts along −t·rendered_tangent; its power on the handle:
    const double power = -s.rendered_tangent_N * v_t;
    if (power > 0.0) {
      m.friction_positive_work_J += power * dt;
    }
    if (s.depth_m > 0.0 && std::abs(v_t) >= config.friction.rest_speed_m_per_s) {
      const double shown = s.rendered_tangent_N * (v_t > 0.0 ? 1.0 : -1.0);
      err2 += (shown - s.friction_target_N) * (shown - s.friction_target_N);
      sum_n += s.hand_normal_N;
      sum_n2 += s.hand_normal_N * s.hand_normal_N;
      ++sliding;
    }
  }
  if (sliding > 0) {
    m.friction_rms_error_N = std::sqrt(err2 / sliding);
    const double mean = sum_n / sliding;
    m.normal_force_std_N = std::sqrt(std::max(0.0, sum_n2 / sliding - mean * mean));
  }
  m.slide_mm = 1e3 * (r.samples.back().position_m - config.hand.start_m).dot(t);
  return r;
}

}  // namespace teleop::device::hybrid
