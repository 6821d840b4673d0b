// The `device.cobot` section reader (docs/cobot.md, docs/configuration.md): every key, its range and the checks
// that span keys (dof, role, rig, fieldbus node ids).

#include <cmath>
#include <string>
#include <vector>

#include "cobot_backend_private.hpp"
#include "cobot_keys.hpp"
#include "teleop/config/key_table.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/can_port_yaml.hpp"

namespace teleop::device::cobot {
namespace {

using config::Field;
using config::Finite;
using config::Map;
using config::Positive;

void ReadOperator(const Field& f, CobotOperatorScript& op) {
  const Map map(f, config::KeysUnder(keys::All(), "operator."));
  op.enabled = true;
  op.speed_m_per_s = config::ReadNumber(map, keys::kOperatorSpeed);
  op.direction_deg = config::ReadNumber(map, keys::kOperatorDirection);
  op.then_at_s = config::ReadNumber(map, keys::kOperatorThenAt);
  op.then_direction_deg = config::ReadNumber(map, keys::kOperatorThenDirection);
  op.max_force_N = config::ReadNumber(map, keys::kOperatorMaxForce);
}

void ReadBicycle(const Field& f, CobotBackendConfig& c) {
  std::vector<std::string> names = config::KeysUnder(keys::All(), "bicycle.");
  names.emplace_back("hold_heading_deg");  // absent: no heading constraint (not in the table: it has no default)
  const Map map(f, names);
  c.bicycle.geometry.half_wheelbase_m = config::ReadNumber(map, keys::kHalfWheelbase);
  c.bicycle.plate_mass_kg = config::ReadNumber(map, keys::kPlateMass);
  c.bicycle.plate_inertia_kgm2 = config::ReadNumber(map, keys::kPlateInertia);
  c.bicycle_caster.singularity_threshold = config::ReadNumber(map, keys::kSingularityThreshold);
  c.bicycle_caster.singularity_guard = config::ReadBool(map, keys::kSingularityGuard);
  if (auto v = map.Optional("hold_heading_deg")) {
    c.bicycle_caster.heading_constraint = true;
    c.bicycle_caster.heading_target_rad = Finite(*v) * config::kDeg;
  }
  c.bicycle_caster.heading_bandwidth_per_s = config::ReadNumber(map, keys::kHeadingBandwidth);
}

/// A direction key (-1..1 in its table): 1 or -1, a drive's or an encoder's direction against the model's.
double ReadSign(const Map& map, const config::KeySpec& spec) {
  const int sign = config::ReadInteger(map, spec);
  if (sign == 0) map.Required(config::LeafOf(spec)).Fail("must be 1 or -1, got 0");
  return static_cast<double>(sign);
}

void ReadSteering(const Field& f, CobotFieldbusConfig& c) {
  const Map map(f, config::KeysUnder(keys::All(), "fieldbus.steering."));
  if (auto v = map.Optional("mode"); v && v->AsString() == "velocity") {
    v->Fail(
        "velocity mode (cyclic synchronous velocity, 0x6060 = 9) is not supported by the cobot rig, which steers "
        "in cyclic synchronous torque (mode 10): the steering-velocity loop of eq 3c runs on the host, "
        "Γ = K2·(ω_c − ω), so that its time constant τ (steering_time_constant_s) is the one the tracker's eq 10/11 "
        "bound and its guard use; in mode 9 the drive's own velocity loop would set τ. Use mode: torque");
  }
  (void)config::ReadChoice(map, keys::kSteeringMode);  // torque, the only word
  fieldbus::Cia402DriveConfig& d = c.steering.drive;
  d.node_id = static_cast<std::uint8_t>(config::ReadInteger(map, keys::kSteeringNodeId));
  c.steering.gear_ratio = config::ReadNumber(map, keys::kSteeringGearRatio);
  d.scaling.position_rad_per_count = config::ReadNumber(map, keys::kSteeringPositionScale);
  d.scaling.velocity_rad_per_s_per_unit = config::ReadNumber(map, keys::kSteeringVelocityScale);
  d.scaling.sign = ReadSign(map, keys::kSteeringDirection);
  d.scaling.rated_torque_Nm = config::ReadNumber(map, keys::kSteeringRatedTorque);
  d.max_torque_Nm = config::ReadNumber(map, keys::kSteeringMaxTorque);
  c.steering_offset_rad = config::ReadNumber(map, keys::kSteeringOffset) * config::kDeg;
  c.steering.max_angle_jump_rad = config::ReadNumber(map, keys::kSteeringMaxJump);
  c.steering.hold_stiffness_Nm_per_rad = config::ReadNumber(map, keys::kSteeringHoldStiffness);
  c.steering.hold_damping_Nms_per_rad = config::ReadNumber(map, keys::kSteeringHoldDamping);
  d.drive_heartbeat_period_ms = config::ReadNumber(map, keys::kSteeringHeartbeatPeriod);
  d.heartbeat_timeout_ms = config::ReadNumber(map, keys::kSteeringHeartbeatTimeout);
  if (d.heartbeat_timeout_ms <= d.drive_heartbeat_period_ms) {
    f.Fail("heartbeat_timeout_ms (" + config::Num(d.heartbeat_timeout_ms) + ") must exceed heartbeat_period_ms (" +
           config::Num(d.drive_heartbeat_period_ms) + ")");
  }
  d.stale_after_ms = config::ReadNumber(map, keys::kSteeringStale);
}

void ReadSensors(const Field& f, CobotFieldbusConfig& c) {
  const Map map(f, config::KeysUnder(keys::All(), "fieldbus.sensors."));
  CobotSensorNodeConfig& s = c.sensors;
  if (auto v = map.Optional("source"); v && v->AsString() == "drive") {
    v->Fail(
        "the wheel encoder and the handle force from the steering drive's PDOs are not supported (the CiA 402 "
        "client maps position, velocity and torque only); use source: node (a separate CAN node)");
  }
  (void)config::ReadChoice(map, keys::kSensorsSource);  // node, the only word
  s.node_id = static_cast<std::uint8_t>(config::ReadInteger(map, keys::kSensorsNodeId));
  s.wheel_cob_id = static_cast<std::uint32_t>(config::ReadInteger(map, keys::kSensorsWheelCobId));
  s.force_cob_id = static_cast<std::uint32_t>(config::ReadInteger(map, keys::kSensorsForceCobId));
  s.brake_cob_id = static_cast<std::uint32_t>(config::ReadInteger(map, keys::kSensorsBrakeCobId));
  s.wheel_sign = ReadSign(map, keys::kSensorsWheelDirection);
  s.force_N_per_unit = config::ReadNumber(map, keys::kSensorsForceScale);
  s.stale_after_ms = config::ReadNumber(map, keys::kSensorsStale);
  s.max_wheel_step_m = config::ReadNumber(map, keys::kSensorsMaxWheelStep);
  if (s.WheelCobId() == s.ForceCobId()) f.Fail("the wheel and force TPDOs need different COB-IDs");
}

void ReadFieldbus(const Field& f, CobotBackendConfig& c) {
  std::vector<std::string> names = config::KeysUnder(keys::All(), "fieldbus.");
  names.emplace_back("can");  // the shared CAN port section (fieldbus::ReadCanPortSection), not in the table
  const Map map(f, names);
  CobotFieldbusConfig& b = c.fieldbus;
  fieldbus::ReadCanPortSection(map.Required("can"), b.can);
  b.steering.drive.cycle_period_s = config::ReadNumber(map, keys::kFieldbusCyclePeriod) * 1e-3;
  ReadSteering(map.Required(config::LeafOf(keys::kSteeringSection)), b);
  const Field sensors = map.Required(config::LeafOf(keys::kSensorsSection));
  ReadSensors(sensors, b);
  if (b.sensors.node_id == b.steering.drive.node_id || b.sensors.node_id == b.steering.drive.host_node_id) {
    sensors.Fail("node_id " + std::to_string(b.sensors.node_id) +
                 " is taken (the steering drive's node id, or the host's heartbeat id " +
                 std::to_string(b.steering.drive.host_node_id) + ")");
  }
  b.first_frames_timeout_ms = config::ReadNumber(map, keys::kFirstFramesTimeout);
}

/// The plant, its sensors and the virtual-wall controller: the top-level keys with a number, a word or true/false.
/// Returns τ of the steering-velocity loop (K2 comes from it once the plant is known).
double ReadPlantAndController(const Map& map, CobotBackendConfig& c) {
  UnicyclePlantConfig& p = c.unicycle.plant;
  CobotSensorConfig& s = c.unicycle.sensors;
  VirtualWallConfig& w = c.unicycle.controller;
  c.kind = config::ReadChoiceAs<CobotBackendConfig::Kind>(map, keys::kKind);
  p.cart_mass_kg = config::ReadNumber(map, keys::kCartMass);
  p.rolling_damping_Ns_per_m = config::ReadNumber(map, keys::kRollingDamping);
  p.steering_inertia_kgm2 = config::ReadNumber(map, keys::kSteeringInertia);
  p.steering_damping_Nms_per_rad = config::ReadNumber(map, keys::kSteeringDamping);
  p.max_steering_torque_Nm = config::ReadNumber(map, keys::kMaxSteeringTorque);
  p.cornering_stiffness_N_per_rad = config::ReadNumber(map, keys::kCorneringStiffness);
  p.brake_max_force_N = config::ReadNumber(map, keys::kBrakeMaxForce);
  p.friction_coefficient = config::ReadNumber(map, keys::kFrictionCoefficient);
  p.normal_load_N = config::ReadNumber(map, keys::kNormalLoad);
  s.wheel_radius_m = config::ReadNumber(map, keys::kWheelRadius);
  s.wheel_encoder_counts_per_rev = config::ReadInteger(map, keys::kWheelEncoderCounts);
  s.steering_encoder_counts_per_rev = config::ReadInteger(map, keys::kSteeringEncoderCounts);
  s.position_resolution_m = config::ReadNumber(map, keys::kPositionResolution);
  s.force_resolution_N = config::ReadNumber(map, keys::kForceResolution);
  // One mass in every direction (as the bicycle): along the wheel the operator feels the cart itself, so the caster
  // asks for the same mass across it (eq 2 with 1/K1 = m, above the speed floor).
  w.caster.k1_per_kg = 1.0 / p.cart_mass_kg;
  w.caster.speed_floor_m_per_s = config::ReadNumber(map, keys::kSpeedFloor);
  w.tracker.lookahead_m = config::ReadNumber(map, keys::kLookahead);
  w.tracker.gain_form = config::ReadChoiceAs<ConstraintTrackerConfig::GainForm>(map, keys::kGainForm);
  w.tracker.p_gain_scale = config::ReadNumber(map, keys::kPGainScale);
  w.tracker.theta_gain_scale = config::ReadNumber(map, keys::kThetaGainScale);
  w.tracker.integral_gain_per_m3 = config::ReadNumber(map, keys::kIntegralGain);
  w.overlay_enabled = config::ReadBool(map, keys::kOverlay);
  w.overlay_min_radius_m = config::ReadNumber(map, keys::kOverlayMinRadius);
  w.release_force_N = config::ReadNumber(map, keys::kReleaseForce);
  w.guard.action = config::ReadChoiceAs<StabilityGuardConfig::Action>(map, keys::kStabilityAction);
  w.guard.margin = config::ReadNumber(map, keys::kStabilityMargin);
  c.contact_force_threshold_N = config::ReadNumber(map, keys::kContactForceThreshold);
  const Eigen::Vector2d xy = config::ReadPair(map, keys::kInitialPosition);
  c.initial.position_m = {xy.x(), xy.y()};
  c.initial.heading_rad = config::ReadNumber(map, keys::kInitialHeading) * config::kDeg;
  return config::ReadNumber(map, keys::kSteeringTimeConstant);
}

/// virtual_mass_kg: refused for the bicycle (its virtual mass is its plate's), equal to cart_mass_kg for the unicycle.
void CheckKind(const Map& map, const CobotBackendConfig& c) {
  const double cart_mass_kg = c.unicycle.plant.cart_mass_kg;
  if (c.kind == CobotBackendConfig::Kind::kBicycle) {
    if (auto v = map.Optional("virtual_mass_kg")) {
      v->Fail(
          "not for kind: bicycle; its virtual mass is bicycle.plate_mass_kg: along its wheels the operator feels the "
          "plate's own mass, so the caster must ask for the same mass across them or force and acceleration are not "
          "collinear (Colgate et al. §3.1: a point mass)");
    }
    return;
  }
  if (auto v = map.Optional(keys::kBicycleSection.key)) v->Fail("only for kind: bicycle");
  if (auto v = map.Optional("virtual_mass_kg")) {
    const double mass_kg = Positive(*v, "kg");
    if (std::abs(mass_kg - cart_mass_kg) > 1e-9 * cart_mass_kg) {
      v->Fail("must equal cart_mass_kg (" + std::to_string(cart_mass_kg) +
              " kg; or leave it out): along the wheel the operator feels the cart's own mass, so a different "
              "virtual mass across it makes force and acceleration not collinear (Colgate et al. §3.1: a point "
              "mass; the bicycle refuses the key for the same reason)");
    }
  }
}

/// rig: fieldbus reads the fieldbus section (a unicycle, no simulated operator, a wheel encoder); rig: simulated
/// refuses it.
void ReadRig(const Map& map, CobotBackendConfig& c) {
  const UnicyclePlantConfig& p = c.unicycle.plant;
  const CobotSensorConfig& s = c.unicycle.sensors;
  c.rig = config::ReadChoiceAs<CobotBackendConfig::Rig>(map, keys::kRig);
  if (c.rig != CobotBackendConfig::Rig::kFieldbus) {
    if (auto v = map.Optional(keys::kFieldbusSection.key)) v->Fail("only for rig: fieldbus");
    return;
  }
  const Field rig = map.Required(keys::kRig.key);
  if (c.kind != CobotBackendConfig::Kind::kUnicycle) {
    rig.Fail("the fieldbus rig is a unicycle cobot (one steering drive); kind bicycle is simulated only");
  }
  if (auto v = map.Optional(keys::kOperatorSection.key)) {
    v->Fail("only for rig: simulated (a real rig has a human operator)");
  }
  if (s.wheel_encoder_counts_per_rev < 1) {
    map.Required(keys::kWheelEncoderCounts.key).Fail("the fieldbus rig needs the wheel encoder's counts (>= 1)");
  }
  ReadFieldbus(map.Required(keys::kFieldbusSection.key), c);
  c.fieldbus.sensors.wheel_radius_m = s.wheel_radius_m;
  c.fieldbus.sensors.wheel_counts_per_rev = s.wheel_encoder_counts_per_rev;
  c.fieldbus.sensors.has_brake = p.brake_max_force_N > 0.0;
}

}  // namespace

CobotBackendConfig ReadCobot(const Field* section, int dof, Role role) {
  if (role == Role::kSlave) {
    const std::string why =
        "a cobot cannot be the slave: it is passive (its motors only steer its wheels, they cannot push), so it can "
        "neither follow the master's motion nor apply a force to the environment, and the coupling force would be "
        "rendered as 'blocked slave' walls; use backend: cobot on the master (role: master) and a slave backend that "
        "can move (loopback, hybrid, cia402, ...)";
    if (section != nullptr) section->Fail(why);
    throw Error("device.cobot: " + why);
  }
  CobotBackendConfig c;
  double tau_s = keys::kSteeringTimeConstant.default_value;
  if (section != nullptr) {
    std::vector<std::string> names = config::KeysUnder(keys::All(), "");
    names.emplace_back("virtual_mass_kg");  // no default of its own: equal to cart_mass_kg or refused (CheckKind)
    const Map map(*section, names);
    tau_s = ReadPlantAndController(map, c);
    if (auto v = map.Optional(keys::kOperatorSection.key)) ReadOperator(*v, c.op);
    if (auto v = map.Optional(keys::kBicycleSection.key)) ReadBicycle(*v, c);
    CheckKind(map, c);
    ReadRig(map, c);
    if (c.unicycle.controller.guard.action == StabilityGuardConfig::Action::kBrake &&
        c.unicycle.plant.brake_max_force_N <= 0.0) {
      map.Required(keys::kStabilityAction.key).Fail("brake needs a wheel brake: set brake_max_force_N > 0");
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
    c.bicycle_caster.friction_compensation_Nms_per_rad = c.bicycle.steering_damping_Nms_per_rad;
    c.bicycle_caster.rolling_damping_Ns_per_m = c.bicycle.rolling_damping_Ns_per_m;
    c.bicycle_caster.virtual_mass_kg = c.bicycle.plate_mass_kg;  // isotropic: the plate's mass in every direction
    c.bicycle_caster.virtual_inertia_kgm2 = c.bicycle.plate_inertia_kgm2;
    c.bicycle_caster.speed_floor_m_per_s = c.unicycle.controller.caster.speed_floor_m_per_s;
  } catch (const Error& e) {
    if (section != nullptr) section->Fail(e.what());
    throw;
  }
  return c;
}

}  // namespace teleop::device::cobot
