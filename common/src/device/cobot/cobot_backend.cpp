// The `cobot` backend: the simulated unicycle or bicycle cobot of Colgate et al. (docs/cobot.md, `device.cobot`).

#include "teleop/device/cobot/cobot_backend.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "teleop/config/yaml_reader.hpp"

namespace teleop::device::cobot {
namespace {

using config::Field;
using config::Finite;
using config::Map;
using config::NonNegative;
using config::Positive;

constexpr double kDeg = std::numbers::pi / 180.0;
const std::string kName = "cobot";

int ReadCount(const Field& f) {
  const double v = NonNegative(f, "counts per revolution (0 = ideal)");
  if (v != std::floor(v) || v > 1e9) f.Fail("must be a whole number of counts, got " + config::Num(v));
  return static_cast<int>(v);
}

void ReadOperator(const Field& f, CobotOperatorScript& op) {
  const Map map(f, {"speed_m_per_s", "direction_deg", "then_at_s", "then_direction_deg", "max_force_N"});
  op.enabled = true;
  if (auto v = map.Optional("speed_m_per_s")) op.speed_m_per_s = Positive(*v, "m/s");
  if (auto v = map.Optional("direction_deg")) op.direction_deg = Finite(*v);
  if (auto v = map.Optional("then_at_s")) op.then_at_s = NonNegative(*v, "s (0 = never)");
  if (auto v = map.Optional("then_direction_deg")) op.then_direction_deg = Finite(*v);
  if (auto v = map.Optional("max_force_N")) op.max_force_N = Positive(*v, "N");
}

void ReadBicycle(const Field& f, CobotBackendConfig& c) {
  const Map map(f, {"half_wheelbase_m", "plate_mass_kg", "plate_inertia_kgm2", "virtual_inertia_kgm2",
                    "singularity_threshold", "singularity_guard"});
  if (auto v = map.Optional("half_wheelbase_m")) c.bicycle.geometry.half_wheelbase_m = Positive(*v, "m");
  if (auto v = map.Optional("plate_mass_kg")) c.bicycle.plate_mass_kg = Positive(*v, "kg");
  if (auto v = map.Optional("plate_inertia_kgm2")) c.bicycle.plate_inertia_kgm2 = Positive(*v, "kg·m²");
  if (auto v = map.Optional("virtual_inertia_kgm2")) c.bicycle_caster.virtual_inertia_kgm2 = Positive(*v, "kg·m²");
  if (auto v = map.Optional("singularity_threshold")) {
    c.bicycle_caster.singularity_threshold = config::InRange(*v, 0.0, 0.99, "");
  }
  if (auto v = map.Optional("singularity_guard")) c.bicycle_caster.singularity_guard = v->AsBool();
}

CobotBackendConfig ReadCobot(const Field* section, int dof) {
  CobotBackendConfig c;
  double tau_s = 0.02;
  if (section != nullptr) {
    const Map map(*section, {"kind",
                             "cart_mass_kg",
                             "rolling_damping_Ns_per_m",
                             "steering_inertia_kgm2",
                             "steering_damping_Nms_per_rad",
                             "max_steering_torque_Nm",
                             "cornering_stiffness_N_per_rad",
                             "brake_max_force_N",
                             "wheel_radius_m",
                             "wheel_encoder_counts_per_rev",
                             "steering_encoder_counts_per_rev",
                             "position_resolution_m",
                             "force_resolution_N",
                             "steering_time_constant_s",
                             "virtual_mass_kg",
                             "speed_floor_m_per_s",
                             "lookahead_m",
                             "gain_form",
                             "p_gain_scale",
                             "theta_gain_scale",
                             "integral_gain_per_m3",
                             "overlay",
                             "overlay_min_radius_m",
                             "release_force_N",
                             "stability_action",
                             "stability_margin",
                             "contact_force_threshold_N",
                             "initial_position_m",
                             "initial_heading_deg",
                             "operator",
                             "bicycle"});
    UnicyclePlantConfig& p = c.unicycle.plant;
    CobotSensorConfig& s = c.unicycle.sensors;
    VirtualWallConfig& w = c.unicycle.controller;
    if (auto v = map.Optional("kind")) {
      const std::string kind = v->AsString();
      if (kind == "unicycle") {
        c.kind = CobotBackendConfig::Kind::kUnicycle;
      } else if (kind == "bicycle") {
        c.kind = CobotBackendConfig::Kind::kBicycle;
      } else {
        v->Fail("must be unicycle or bicycle, got '" + kind + "'");
      }
    }
    if (auto v = map.Optional("cart_mass_kg")) p.cart_mass_kg = Positive(*v, "kg");
    if (auto v = map.Optional("rolling_damping_Ns_per_m")) p.rolling_damping_Ns_per_m = NonNegative(*v, "N·s/m");
    if (auto v = map.Optional("steering_inertia_kgm2")) p.steering_inertia_kgm2 = Positive(*v, "kg·m²");
    if (auto v = map.Optional("steering_damping_Nms_per_rad")) {
      p.steering_damping_Nms_per_rad = NonNegative(*v, "N·m·s/rad");
    }
    if (auto v = map.Optional("max_steering_torque_Nm")) p.max_steering_torque_Nm = Positive(*v, "N·m");
    if (auto v = map.Optional("cornering_stiffness_N_per_rad")) {
      p.cornering_stiffness_N_per_rad = NonNegative(*v, "N/rad (0 = no slip)");
    }
    if (auto v = map.Optional("brake_max_force_N")) p.brake_max_force_N = NonNegative(*v, "N (0 = no brake)");
    if (auto v = map.Optional("wheel_radius_m")) s.wheel_radius_m = Positive(*v, "m");
    if (auto v = map.Optional("wheel_encoder_counts_per_rev")) s.wheel_encoder_counts_per_rev = ReadCount(*v);
    if (auto v = map.Optional("steering_encoder_counts_per_rev")) s.steering_encoder_counts_per_rev = ReadCount(*v);
    if (auto v = map.Optional("position_resolution_m")) s.position_resolution_m = NonNegative(*v, "m (0 = ideal)");
    if (auto v = map.Optional("force_resolution_N")) s.force_resolution_N = NonNegative(*v, "N (0 = ideal)");
    if (auto v = map.Optional("steering_time_constant_s")) tau_s = Positive(*v, "s");
    if (auto v = map.Optional("virtual_mass_kg")) w.caster.k1_per_kg = 1.0 / Positive(*v, "kg");
    if (auto v = map.Optional("speed_floor_m_per_s")) w.caster.speed_floor_m_per_s = Positive(*v, "m/s");
    if (auto v = map.Optional("lookahead_m")) w.tracker.lookahead_m = Positive(*v, "m");
    if (auto v = map.Optional("gain_form")) {
      const std::string form = v->AsString();
      if (form == "small_angle") {
        w.tracker.gain_form = ConstraintTrackerConfig::GainForm::kSmallAngle;
      } else if (form == "circular") {
        w.tracker.gain_form = ConstraintTrackerConfig::GainForm::kCircular;
      } else {
        v->Fail("must be small_angle (eq 8) or circular (eq 7), got '" + form + "'");
      }
    }
    if (auto v = map.Optional("p_gain_scale")) w.tracker.p_gain_scale = Positive(*v, "");
    if (auto v = map.Optional("theta_gain_scale")) w.tracker.theta_gain_scale = Positive(*v, "");
    if (auto v = map.Optional("integral_gain_per_m3")) w.tracker.integral_gain_per_m3 = NonNegative(*v, "1/m³");
    if (auto v = map.Optional("overlay")) w.overlay_enabled = v->AsBool();
    if (auto v = map.Optional("overlay_min_radius_m")) w.overlay_min_radius_m = NonNegative(*v, "m");
    if (auto v = map.Optional("release_force_N")) w.release_force_N = NonNegative(*v, "N");
    if (auto v = map.Optional("stability_action")) {
      const std::string action = v->AsString();
      if (action == "warn") {
        w.guard.action = StabilityGuardConfig::Action::kWarn;
      } else if (action == "lengthen_lookahead") {
        w.guard.action = StabilityGuardConfig::Action::kLengthenLookahead;
      } else if (action == "brake") {
        w.guard.action = StabilityGuardConfig::Action::kBrake;
      } else {
        v->Fail("must be warn, lengthen_lookahead or brake, got '" + action + "'");
      }
    }
    if (auto v = map.Optional("stability_margin")) w.guard.margin = config::InRange(*v, 0.05, 1.0, "");
    if (auto v = map.Optional("contact_force_threshold_N")) c.contact_force_threshold_N = Positive(*v, "N");
    if (auto v = map.Optional("initial_position_m")) {
      const DofVector xy = config::ReadDofVector(*v, 2, Finite);
      c.initial.position_m = {xy[0], xy[1]};
    }
    if (auto v = map.Optional("initial_heading_deg")) c.initial.heading_rad = Finite(*v) * kDeg;
    if (auto v = map.Optional("operator")) ReadOperator(*v, c.op);
    if (auto v = map.Optional("bicycle")) ReadBicycle(*v, c);
    if (w.guard.action == StabilityGuardConfig::Action::kBrake && p.brake_max_force_N <= 0.0) {
      map.Required("stability_action").Fail("brake needs a wheel brake: set brake_max_force_N > 0");
    }
  }
  const int expected = c.kind == CobotBackendConfig::Kind::kUnicycle ? 2 : 3;
  if (dof != expected) {
    const std::string what = c.kind == CobotBackendConfig::Kind::kUnicycle ? "a unicycle cobot is planar: dof 2 (x, y)"
                                                                           : "a bicycle cobot has dof 3 (x, y, θ)";
    if (section != nullptr) section->Fail(what + "; the process has dof " + std::to_string(dof));
    throw Error("device.cobot: " + what + "; the process has dof " + std::to_string(dof));
  }
  try {
    const double k2 = SteeringGainFor(c.unicycle.plant, tau_s);
    c.unicycle.controller.caster.k2_Nms_per_rad = k2;
    c.unicycle.controller.tracker.k2_Nms_per_rad = k2;
    c.unicycle.controller.caster.friction_compensation_Nms_per_rad = c.unicycle.plant.steering_damping_Nms_per_rad;
    c.bicycle.steering_inertia_kgm2 = c.unicycle.plant.steering_inertia_kgm2;
    c.bicycle.steering_damping_Nms_per_rad = c.unicycle.plant.steering_damping_Nms_per_rad;
    c.bicycle.max_steering_torque_Nm = c.unicycle.plant.max_steering_torque_Nm;
    c.bicycle_caster.k2_Nms_per_rad = k2;
    c.bicycle_caster.virtual_mass_kg = 1.0 / c.unicycle.controller.caster.k1_per_kg;
    c.bicycle_caster.speed_floor_m_per_s = c.unicycle.controller.caster.speed_floor_m_per_s;
  } catch (const Error& e) {
    if (section != nullptr) section->Fail(e.what());
    throw;
  }
  return c;
}

/// The scripted operator's push (N, world) for a cart moving at `velocity` (m/s, world).
Vec2 OperatorPush(const CobotOperatorScript& op, double time_s, const Vec2& velocity, double period_s,
                  double& integral_N) noexcept {
  if (!op.enabled) return Vec2::Zero();
  const bool turned = op.then_at_s > 0.0 && time_s >= op.then_at_s;
  const Vec2 direction = UnitAt((turned ? op.then_direction_deg : op.direction_deg) * kDeg);
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

bool CommandUsable(const Command& command, int dof) noexcept {
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

}  // namespace

// ---------------------------------------------------------------- unicycle

UnicycleCobotDevice::UnicycleCobotDevice(const CobotBackendConfig& config)
    : config_(config),
      capabilities_(CobotCapabilities(2, config.unicycle.plant.brake_max_force_N)),
      rig_(config.unicycle, Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true), config.initial),
      walls_(config.contact_force_threshold_N) {
  rig_.controller().SetWallActive(false);
  last_.position_m = config.initial.position_m;
  last_.heading_rad = config.initial.heading_rad;
}

const std::string& UnicycleCobotDevice::name() const noexcept { return kName; }

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
  if (!out.position_m.allFinite() || !out.velocity_m_per_s.allFinite() || !out.force_N.allFinite()) {
    out.faults |= kFaultNonFiniteSensor;
  }
}

void UnicycleCobotDevice::Write(const Command& command) noexcept {
  if (!CommandUsable(command, 2)) {
    pending_faults_ |= kFaultDriver;
    rig_.SetLocked(true);
    return;
  }
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

void UnicycleCobotDevice::SetSafe() noexcept { rig_.SetLocked(true); }

// ---------------------------------------------------------------- bicycle

BicycleCobotDevice::BicycleCobotDevice(const CobotBackendConfig& config)
    : config_(config), capabilities_(CobotCapabilities(3, 0.0)) {
  Validate(config_.bicycle);
  Validate(config_.bicycle_caster);
  state_.pose.position_m = config.initial.position_m;
  state_.pose.angle_rad = config.initial.heading_rad;
}

const std::string& BicycleCobotDevice::name() const noexcept { return kName; }

void BicycleCobotDevice::Read(Reading& out) noexcept {
  out.position_m = DofVector::Zero(3);
  out.velocity_m_per_s = DofVector::Zero(3);
  out.force_N = DofVector::Zero(3);
  out.rendered_force_N = DofVector::Zero(3);
  out.position_m << state_.pose.position_m.x(), state_.pose.position_m.y(), state_.pose.angle_rad;
  out.velocity_m_per_s << state_.twist(0), state_.twist(1), state_.twist(2);
  out.faults = pending_faults_;
  pending_faults_ = kFaultNone;
  if (!out.position_m.allFinite() || !out.velocity_m_per_s.allFinite()) out.faults |= kFaultNonFiniteSensor;
}

void BicycleCobotDevice::Write(const Command& command) noexcept {
  if (!CommandUsable(command, 3)) {
    pending_faults_ |= kFaultDriver;
    safe_ = true;
    return;
  }
  for (int i = 0; i < command.constraint_count; ++i) {
    if (command.constraints[static_cast<std::size_t>(i)].penetration_m > 0.0) {
      pending_faults_ |= kFaultDriver;  // constraints are not rendered by the bicycle backend (docs/cobot.md)
    }
  }
  safe_ = false;
}

void BicycleCobotDevice::Update(double period_s) noexcept {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) {
    pending_faults_ |= kFaultDriver;
    return;
  }
  const Vec2 force =
      OperatorPush(config_.op, time_s_, Vec2(state_.twist(0), state_.twist(1)), period_s, operator_integral_N_);
  BicyclePlantInput in;
  in.handle_force_N = force;
  if (safe_) {
    for (std::size_t i = 0; i < 2; ++i) {
      in.steering_torque_Nm[i] = -config_.bicycle_caster.k2_Nms_per_rad * state_.steer_rate_rad_per_s[i];
    }
  } else {
    const BicycleCasterOutput out =
        BicycleCasterStep(config_.bicycle_caster, config_.bicycle.geometry, state_, force, 0.0);
    in.steering_torque_Nm = out.steering_torque_Nm;
  }
  Step(config_.bicycle, in, period_s, state_);
  time_s_ += period_s;
}

void BicycleCobotDevice::SetSafe() noexcept { safe_ = true; }

// ---------------------------------------------------------------- registration

DeviceBackend CobotBackend() {
  DeviceBackend b;
  b.name = kName;
  b.description =
      "simulated cobot (Colgate et al.): a steered wheel renders walls passively; unicycle (x, y) or bicycle (x, y, θ)";
  b.nominal = CobotCapabilities(2, 0.0);
  b.keys = {
      {"kind", "unicycle (dof 2, default) or bicycle (dof 3, caster only)"},
      {"cart_mass_kg", "moving mass (kg), > 0; default 10"},
      {"rolling_damping_Ns_per_m", "rolling resistance (N·s/m), >= 0; default 20"},
      {"steering_inertia_kgm2", "wheel assembly about the steering axis (kg·m²), > 0; default 0.002"},
      {"steering_damping_Nms_per_rad", "steering friction b (N·m·s/rad), >= 0; default 0.004"},
      {"max_steering_torque_Nm", "steering motor limit (N·m), > 0; default 2"},
      {"cornering_stiffness_N_per_rad", "wheel slip model C (N/rad), >= 0, 0 = no slip; default 500"},
      {"brake_max_force_N", "wheel brake (N), >= 0, 0 = none; default 0"},
      {"wheel_radius_m", "wheel radius (m), > 0; default 0.05"},
      {"wheel_encoder_counts_per_rev", "wheel encoder counts, >= 0 (0 = ideal); default 16384"},
      {"steering_encoder_counts_per_rev", "steering encoder counts, >= 0 (0 = ideal); default 16384"},
      {"position_resolution_m", "absolute position sensing step (m), >= 0; default 1e-5"},
      {"force_resolution_N", "handle force sensor step (N), >= 0; default 0.01"},
      {"steering_time_constant_s", "tau of the steering-velocity loop (eq 3c), sets K2 = J/tau - b; default 0.02"},
      {"virtual_mass_kg", "1/K1 of the virtual caster (eq 2) (kg), > 0; default 10"},
      {"speed_floor_m_per_s", "epsilon of eq 2 (m/s), > 0; default 0.02"},
      {"lookahead_m", "L of eqs 7-8 (m), > 0; default 0.05"},
      {"gain_form", "small_angle (eq 8, default) or circular (eq 7)"},
      {"p_gain_scale", "multiplies the penetration gain, > 0; default 1"},
      {"theta_gain_scale", "multiplies the out-of-tangency gain, > 0; default 1"},
      {"integral_gain_per_m3", "integral action on p (1/m³), >= 0; default 0"},
      {"overlay", "constraint overlay (§5) on/off; default true"},
      {"overlay_min_radius_m", "overlay activation radius (m), >= 0; default 0.1"},
      {"release_force_N", "pull-off force that releases a wall (N), >= 0; default 1"},
      {"stability_action", "above the eq 10 bound: warn (default), lengthen_lookahead or brake"},
      {"stability_margin", "act at this fraction of the eq 10 speed, 0.05..1; default 0.8"},
      {"contact_force_threshold_N", "coupling force that means a blocked slave (N), > 0; default 2"},
      {"initial_position_m", "start position [x, y] (m); default [0, 0]"},
      {"initial_heading_deg", "start heading (deg from +x); default 0"},
      {"operator", "simulated operator (master without a human)"},
      {"operator.speed_m_per_s", "speed the operator holds (m/s), > 0; default 0.2"},
      {"operator.direction_deg", "push direction (deg from +x); default 0"},
      {"operator.then_at_s", "time of the change of direction (s), 0 = never; default 0"},
      {"operator.then_direction_deg", "push direction after then_at_s (deg); default 0"},
      {"operator.max_force_N", "largest push (N), > 0; default 60"},
      {"bicycle", "bicycle cobot plate (kind: bicycle)"},
      {"bicycle.half_wheelbase_m", "wheels at ±this on the plate's x axis (m), > 0; default 0.2"},
      {"bicycle.plate_mass_kg", "plate mass (kg), > 0; default 12"},
      {"bicycle.plate_inertia_kgm2", "plate inertia (kg·m²), > 0; default 0.4"},
      {"bicycle.virtual_inertia_kgm2", "caster's virtual inertia (kg·m²), > 0; default 0.4"},
      {"bicycle.singularity_threshold", "singularity measure below which the guard acts, 0..0.99; default 0.05"},
      {"bicycle.singularity_guard", "keep the wheels off the singular configuration; default true"},
  };
  b.section_required = false;
  b.read = [](const Field* section, const SectionContext& context) -> std::any {
    return ReadCobot(section, context.dof);
  };
  b.make = [](const DeviceConfig& config) -> std::unique_ptr<Device> {
    const CobotBackendConfig c =
        config.section.has_value() ? config.Section<CobotBackendConfig>() : ReadCobot(nullptr, config.dof);
    const int expected = c.kind == CobotBackendConfig::Kind::kUnicycle ? 2 : 3;
    if (config.dof != expected) {
      throw Error("device.cobot: this cobot has dof " + std::to_string(expected) + ", the process " +
                  std::to_string(config.dof));
    }
    if (c.kind == CobotBackendConfig::Kind::kBicycle) return std::make_unique<BicycleCobotDevice>(c);
    return std::make_unique<UnicycleCobotDevice>(c);
  };
  b.model = [](const DeviceConfig&) {
    return AnalysisModel::NotApplicable(
        "a cobot renders no force along the fixture normal: its walls are steered (kinematic), so the force-loop "
        "stability check does not apply; eq 10 of Colgate et al. does (teleop-scenario cobot-stability)");
  };
  return b;
}

DeviceConfig CobotDeviceConfig(const CobotBackendConfig& config) {
  return DeviceConfig::Of("cobot", config.kind == CobotBackendConfig::Kind::kUnicycle ? 2 : 3, config);
}

}  // namespace teleop::device::cobot

TELEOP_REGISTER_DEVICE(cobot, teleop::device::cobot::CobotBackend())
