// The `cobot` backend: the simulated unicycle or bicycle cobot of Colgate et al. (docs/cobot.md, `device.cobot`).

#include "teleop/device/cobot/cobot_backend.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/cobot/cobot_fieldbus_device.hpp"

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
  const Map map(f, {"half_wheelbase_m", "plate_mass_kg", "plate_inertia_kgm2", "singularity_threshold",
                    "singularity_guard", "hold_heading_deg", "heading_bandwidth_per_s"});
  if (auto v = map.Optional("half_wheelbase_m")) c.bicycle.geometry.half_wheelbase_m = Positive(*v, "m");
  if (auto v = map.Optional("plate_mass_kg")) c.bicycle.plate_mass_kg = Positive(*v, "kg");
  if (auto v = map.Optional("plate_inertia_kgm2")) c.bicycle.plate_inertia_kgm2 = Positive(*v, "kg·m²");
  if (auto v = map.Optional("singularity_threshold")) {
    c.bicycle_caster.singularity_threshold = config::InRange(*v, 0.0, 0.99, "");
  }
  if (auto v = map.Optional("singularity_guard")) c.bicycle_caster.singularity_guard = v->AsBool();
  if (auto v = map.Optional("hold_heading_deg")) {
    c.bicycle_caster.heading_constraint = true;
    c.bicycle_caster.heading_target_rad = Finite(*v) * kDeg;
  }
  if (auto v = map.Optional("heading_bandwidth_per_s")) {
    c.bicycle_caster.heading_bandwidth_per_s = config::InRange(*v, 0.1, 20.0, "rad/s");
  }
}

void ReadCanPort(const Field& f, fieldbus::CanPortConfig& can) {
  const Map map(f, {"medium", "interface", "bus", "connect_timeout_ms"});
  if (auto v = map.Optional("medium")) {
    const std::string medium = v->AsString();
    if (medium == "socketcan") {
      can.medium = transport::CanMedium::kSocketCan;
    } else if (medium == "emulated") {
      can.medium = transport::CanMedium::kEmulatedBus;
    } else {
      v->Fail("must be socketcan (a SocketCAN interface) or emulated (the teleop-canbus daemon), got '" + medium + "'");
    }
  }
  const bool emulated = can.medium == transport::CanMedium::kEmulatedBus;
  if (auto v = map.Optional("interface")) {
    if (emulated) v->Fail("only for medium socketcan");
    can.interface_name = v->AsString();
    if (can.interface_name.empty() || can.interface_name.size() > 15) {
      v->Fail("must be a network interface name of 1..15 characters (e.g. can0), got '" + can.interface_name + "'");
    }
  } else if (!emulated) {
    map.Required("interface");
  }
  if (auto v = map.Optional("bus")) {
    if (!emulated) v->Fail("only for medium emulated (the teleop-canbus daemon's address)");
    const std::string text = v->AsString();
    const std::size_t colon = text.rfind(':');
    const std::string port = colon == std::string::npos ? "" : text.substr(colon + 1);
    if (colon == std::string::npos || colon == 0 || port.empty() || port.size() > 5 ||
        port.find_first_not_of("0123456789") != std::string::npos || std::stoi(port) < 1 || std::stoi(port) > 65535) {
      v->Fail("must be \"IPv4:PORT\" like \"127.0.0.1:47300\", got '" + text + "'");
    }
    can.emulated_bus_host = text.substr(0, colon);
    can.emulated_bus_port = static_cast<std::uint16_t>(std::stoi(port));
  }
  if (auto v = map.Optional("connect_timeout_ms")) can.connect_timeout_ms = Positive(*v, "ms");
}

std::uint8_t ReadNodeId(const Field& f) { return static_cast<std::uint8_t>(config::IntInRange(f, 1, 127)); }

void ReadSteering(const Field& f, CobotFieldbusConfig& c) {
  const Map map(f,
                {"node_id", "mode", "gear_ratio", "position_rad_per_count", "velocity_rad_per_s_per_unit", "direction",
                 "rated_torque_Nm", "max_torque_Nm", "offset_deg", "max_angle_jump_rad", "hold_stiffness_Nm_per_rad",
                 "hold_damping_Nms_per_rad", "heartbeat_period_ms", "heartbeat_timeout_ms", "stale_after_ms"});
  fieldbus::Cia402DriveConfig& d = c.steering.drive;
  d.node_id = ReadNodeId(map.Required("node_id"));
  if (auto v = map.Optional("mode")) {
    const std::string mode = v->AsString();
    if (mode == "velocity") {
      v->Fail(
          "velocity mode (cyclic synchronous velocity, 0x6060 = 9) is not supported by the CiA 402 client, which runs "
          "cyclic synchronous torque only; use mode: torque (the steering-velocity loop of eq 3c then runs on the "
          "host, Γ = K2·(ω_c − ω))");
    }
    if (mode != "torque") v->Fail("must be torque, got '" + mode + "'");
  }
  if (auto v = map.Optional("gear_ratio")) c.steering.gear_ratio = Positive(*v, "motor rad per steering rad");
  if (auto v = map.Optional("position_rad_per_count")) d.scaling.position_rad_per_count = Positive(*v, "rad");
  if (auto v = map.Optional("velocity_rad_per_s_per_unit")) {
    d.scaling.velocity_rad_per_s_per_unit = Positive(*v, "rad/s");
  }
  if (auto v = map.Optional("direction")) {
    const double sign = Finite(*v);
    if (sign != 1.0 && sign != -1.0) v->Fail("must be 1 or -1, got " + config::Num(sign));
    d.scaling.sign = sign;
  }
  if (auto v = map.Optional("rated_torque_Nm")) d.scaling.rated_torque_Nm = Positive(*v, "N·m");
  if (auto v = map.Optional("max_torque_Nm")) d.max_torque_Nm = Positive(*v, "N·m");
  if (auto v = map.Optional("offset_deg")) c.steering_offset_rad = Finite(*v) * kDeg;
  if (auto v = map.Optional("max_angle_jump_rad")) c.steering.max_angle_jump_rad = Positive(*v, "rad");
  if (auto v = map.Optional("hold_stiffness_Nm_per_rad"))
    c.steering.hold_stiffness_Nm_per_rad = Positive(*v, "N·m/rad");
  if (auto v = map.Optional("hold_damping_Nms_per_rad")) {
    c.steering.hold_damping_Nms_per_rad = NonNegative(*v, "N·m·s/rad");
  }
  if (auto v = map.Optional("heartbeat_period_ms"))
    d.drive_heartbeat_period_ms = config::InRange(*v, 1.0, 10000.0, "ms");
  if (auto v = map.Optional("heartbeat_timeout_ms")) d.heartbeat_timeout_ms = config::InRange(*v, 1.0, 60000.0, "ms");
  if (d.heartbeat_timeout_ms <= d.drive_heartbeat_period_ms) {
    f.Fail("heartbeat_timeout_ms (" + config::Num(d.heartbeat_timeout_ms) + ") must exceed heartbeat_period_ms (" +
           config::Num(d.drive_heartbeat_period_ms) + ")");
  }
  if (auto v = map.Optional("stale_after_ms")) d.stale_after_ms = Positive(*v, "ms");
}

void ReadSensors(const Field& f, CobotFieldbusConfig& c) {
  const Map map(f, {"source", "node_id", "wheel_cob_id", "force_cob_id", "brake_cob_id", "wheel_direction",
                    "force_N_per_unit", "stale_after_ms", "max_wheel_step_m"});
  CobotSensorNodeConfig& s = c.sensors;
  if (auto v = map.Optional("source")) {
    const std::string source = v->AsString();
    if (source == "drive") {
      v->Fail(
          "the wheel encoder and the handle force from the steering drive's PDOs are not supported (the CiA 402 "
          "client maps position, velocity and torque only); use source: node (a separate CAN node)");
    }
    if (source != "node") v->Fail("must be node, got '" + source + "'");
  }
  s.node_id = ReadNodeId(map.Required("node_id"));
  const auto cob = [](const Field& e) { return static_cast<std::uint32_t>(config::IntInRange(e, 0x081, 0x7FF)); };
  if (auto v = map.Optional("wheel_cob_id")) s.wheel_cob_id = cob(*v);
  if (auto v = map.Optional("force_cob_id")) s.force_cob_id = cob(*v);
  if (auto v = map.Optional("brake_cob_id")) s.brake_cob_id = cob(*v);
  if (auto v = map.Optional("wheel_direction")) {
    const double sign = Finite(*v);
    if (sign != 1.0 && sign != -1.0) v->Fail("must be 1 or -1, got " + config::Num(sign));
    s.wheel_sign = sign;
  }
  if (auto v = map.Optional("force_N_per_unit")) s.force_N_per_unit = Positive(*v, "N");
  if (auto v = map.Optional("stale_after_ms")) s.stale_after_ms = Positive(*v, "ms");
  if (auto v = map.Optional("max_wheel_step_m")) s.max_wheel_step_m = Positive(*v, "m");
  if (s.WheelCobId() == s.ForceCobId()) f.Fail("the wheel and force TPDOs need different COB-IDs");
}

void ReadFieldbus(const Field& f, CobotBackendConfig& c) {
  const Map map(f, {"can", "cycle_period_ms", "steering", "sensors", "first_frames_timeout_ms"});
  CobotFieldbusConfig& b = c.fieldbus;
  ReadCanPort(map.Required("can"), b.can);
  if (auto v = map.Optional("cycle_period_ms")) {
    b.steering.drive.cycle_period_s = config::InRange(*v, 0.125, 100.0, "ms") * 1e-3;
  }
  ReadSteering(map.Required("steering"), b);
  const Field sensors = map.Required("sensors");
  ReadSensors(sensors, b);
  if (b.sensors.node_id == b.steering.drive.node_id || b.sensors.node_id == b.steering.drive.host_node_id) {
    sensors.Fail("node_id " + std::to_string(b.sensors.node_id) +
                 " is taken (the steering drive's node id, or the host's heartbeat id " +
                 std::to_string(b.steering.drive.host_node_id) + ")");
  }
  if (auto v = map.Optional("first_frames_timeout_ms")) b.first_frames_timeout_ms = Positive(*v, "ms");
}

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
                             "friction_coefficient",
                             "normal_load_N",
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
                             "bicycle",
                             "rig",
                             "fieldbus"});
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
    if (auto v = map.Optional("friction_coefficient")) {
      p.friction_coefficient = NonNegative(*v, "(0 = no traction limit)");
    }
    if (auto v = map.Optional("normal_load_N")) p.normal_load_N = NonNegative(*v, "N (0 = cart_mass_kg·g)");
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
    if (c.kind == CobotBackendConfig::Kind::kBicycle) {
      if (auto v = map.Optional("virtual_mass_kg")) {
        v->Fail(
            "not for kind: bicycle; its virtual mass is bicycle.plate_mass_kg: along its wheels the operator feels the "
            "plate's own mass, so the caster must ask for the same mass across them or force and acceleration are not "
            "collinear (Colgate et al. §3.1: a point mass)");
      }
    } else if (auto v = map.Optional("bicycle")) {
      v->Fail("only for kind: bicycle");
    }
    if (auto v = map.Optional("rig")) {
      const std::string rig = v->AsString();
      if (rig == "simulated") {
        c.rig = CobotBackendConfig::Rig::kSimulated;
      } else if (rig == "fieldbus") {
        c.rig = CobotBackendConfig::Rig::kFieldbus;
      } else {
        v->Fail("must be simulated or fieldbus, got '" + rig + "'");
      }
    }
    if (c.rig == CobotBackendConfig::Rig::kFieldbus) {
      const Field rig = map.Required("rig");
      if (c.kind != CobotBackendConfig::Kind::kUnicycle) {
        rig.Fail("the fieldbus rig is a unicycle cobot (one steering drive); kind bicycle is simulated only");
      }
      if (auto v = map.Optional("operator")) v->Fail("only for rig: simulated (a real rig has a human operator)");
      if (s.wheel_encoder_counts_per_rev < 1) {
        map.Required("wheel_encoder_counts_per_rev").Fail("the fieldbus rig needs the wheel encoder's counts (>= 1)");
      }
      ReadFieldbus(map.Required("fieldbus"), c);
      c.fieldbus.sensors.wheel_radius_m = s.wheel_radius_m;
      c.fieldbus.sensors.wheel_counts_per_rev = s.wheel_encoder_counts_per_rev;
      c.fieldbus.sensors.has_brake = p.brake_max_force_N > 0.0;
    } else if (auto v = map.Optional("fieldbus")) {
      v->Fail("only for rig: fieldbus");
    }
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

}  // namespace

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

bool CobotCommandUsable(const Command& command, int dof) noexcept {
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
  out.warnings = last_.control.stability.warning ? kWarningStabilityGuard : kWarningNone;
  if (!out.position_m.allFinite() || !out.velocity_m_per_s.allFinite() || !out.force_N.allFinite()) {
    out.faults |= kFaultNonFiniteSensor;
  }
}

void UnicycleCobotDevice::Write(const Command& command) noexcept {
  if (!CobotCommandUsable(command, 2)) {
    pending_faults_ |= kFaultDriver;
    SetSafe();
    return;
  }
  safe_ = false;
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

void UnicycleCobotDevice::SetSafe() noexcept {
  safe_ = true;
  // Near a fixture (a wall is set) the safe state keeps steering against the last wall: the wheel turns to its
  // tangent (overlay, tracking) and a push into it is refused, as in normal operation; locking the steering there
  // would let a wheel aimed at the wall roll through it. With no wall the steering is locked (and braked).
  rig_.SetLocked(walls_.source() < 0);
}

// ---------------------------------------------------------------- bicycle

namespace {
/// The wall controller of the bicycle's virtual unicycle: the unicycle's, with τ of the steering loop on the
/// bicycle's wheels (K₂ and the wheel inertia are the same).
VirtualWallConfig BicycleWallConfig(const CobotBackendConfig& c) {
  VirtualWallConfig w = c.unicycle.controller;
  w.steering_time_constant_s =
      c.bicycle.steering_inertia_kgm2 / (w.tracker.k2_Nms_per_rad + c.bicycle.steering_damping_Nms_per_rad);
  Validate(w);
  return w;
}
/// Gain that steers each wheel onto the virtual heading (1/s): a quarter of the steering loop's bandwidth.
constexpr double kAlignmentFraction = 0.25;

/// The wheels' common heading modulo π, relative to the plate (the mean of β₀ and β₁ brought within ±π/2 of β₀).
double MeanSteer(const BicyclePlantState& s) noexcept {
  const double b1 = s.steer_rad[0] + 0.5 * WrapAngle(2.0 * (s.steer_rad[1] - s.steer_rad[0]));
  return 0.5 * (s.steer_rad[0] + b1);
}
}  // namespace

double BicycleCobotDevice::virtual_heading_rad() const noexcept { return state_.pose.angle_rad + MeanSteer(state_); }

BicycleCobotDevice::BicycleCobotDevice(const CobotBackendConfig& config)
    : config_(config),
      capabilities_(CobotCapabilities(3, 0.0)),
      controller_(BicycleWallConfig(config), Constraint::Line({0.0, 0.0}, {1.0, 0.0}, true)),
      walls_(config.contact_force_threshold_N) {
  // One isotropic virtual mass (Colgate et al. §3.1, a rigid body): along its wheels the operator feels the plate's
  // own mass and inertia, so the caster asks for the same across them.
  config_.bicycle_caster.virtual_mass_kg = config_.bicycle.plate_mass_kg;
  config_.bicycle_caster.virtual_inertia_kgm2 = config_.bicycle.plate_inertia_kgm2;
  controller_.SetWallActive(false);
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
  const CobotSensorConfig& sensors = config_.unicycle.sensors;
  out.position_m << Quantize(state_.pose.position_m.x(), sensors.position_resolution_m),
      Quantize(state_.pose.position_m.y(), sensors.position_resolution_m), state_.pose.angle_rad;
  out.velocity_m_per_s << state_.twist(0), state_.twist(1), state_.twist(2);
  const Vec2 force = MeasuredForce();
  out.force_N << force.x(), force.y(), 0.0;
  out.faults = pending_faults_;
  pending_faults_ = kFaultNone;
  out.warnings = last_control_.stability.warning ? kWarningStabilityGuard : kWarningNone;
  if (!out.position_m.allFinite() || !out.velocity_m_per_s.allFinite() || !out.force_N.allFinite()) {
    out.faults |= kFaultNonFiniteSensor;
  }
}

Vec2 BicycleCobotDevice::MeasuredForce() const noexcept {
  const double step = config_.unicycle.sensors.force_resolution_N;
  return {Quantize(operator_force_N_.x(), step), Quantize(operator_force_N_.y(), step)};
}

void BicycleCobotDevice::Write(const Command& command) noexcept {
  if (!CobotCommandUsable(command, 3)) {
    pending_faults_ |= kFaultDriver;
    SetSafe();
    return;
  }
  safe_ = false;
  locked_ = false;
  walls_.Apply(command, state_.pose.position_m, Vec2(state_.twist(0), state_.twist(1)), controller_);
}

void BicycleCobotDevice::Update(double period_s) noexcept {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) {
    pending_faults_ |= kFaultDriver;
    return;
  }
  const Vec2 force =
      OperatorPush(config_.op, time_s_, Vec2(state_.twist(0), state_.twist(1)), period_s, operator_integral_N_);
  operator_force_N_ = force;
  const Vec2 measured = MeasuredForce();  // the handle force sensor, as the controllers see it
  // What the controllers see: the position quantized by the position sensing, the steering angles by their
  // encoders. The plate's twist and the steering rates are taken as estimated without error (no estimator model).
  const CobotSensorConfig& sensors = config_.unicycle.sensors;
  BicyclePlantState seen = state_;
  seen.pose.position_m = {Quantize(state_.pose.position_m.x(), sensors.position_resolution_m),
                          Quantize(state_.pose.position_m.y(), sensors.position_resolution_m)};
  const double steer_step = sensors.steering_encoder_counts_per_rev > 0
                                ? 2.0 * std::numbers::pi / sensors.steering_encoder_counts_per_rev
                                : 0.0;
  for (std::size_t i = 0; i < 2; ++i) seen.steer_rad[i] = Quantize(state_.steer_rad[i], steer_step);
  BicyclePlantInput in;
  in.handle_force_N = force;
  if (locked_) {
    for (std::size_t i = 0; i < 2; ++i) {
      in.steering_torque_Nm[i] = -config_.bicycle_caster.k2_Nms_per_rad * state_.steer_rate_rad_per_s[i];
    }
  } else {
    // The reference point as a virtual unicycle: heading ψ_v (the wheels' mean), speed along it, its turn rate.
    const double omega = state_.twist(2);
    const double psi = seen.pose.angle_rad + MeanSteer(seen);
    WallControllerInput wall_in;
    wall_in.position_m = seen.pose.position_m;
    wall_in.steering_angle_rad = psi;
    wall_in.speed_m_per_s = Vec2(state_.twist(0), state_.twist(1)).dot(UnitAt(psi));
    wall_in.steering_rate_rad_per_s = omega + 0.5 * (state_.steer_rate_rad_per_s[0] + state_.steer_rate_rad_per_s[1]);
    wall_in.handle_force_N = measured;
    last_control_ = controller_.Step(wall_in, period_s);
    if (last_control_.mode == WallMode::kCaster) {
      const BicycleCasterOutput out =
          BicycleCasterStep(config_.bicycle_caster, config_.bicycle.geometry, seen, measured, 0.0);
      in.steering_torque_Nm = out.steering_torque_Nm;
    } else {
      // Both wheels turn at the tracker's ω_c and are pulled onto ψ_v (modulo π: a wheel may roll backwards).
      const double k2 = config_.bicycle_caster.k2_Nms_per_rad;
      const double alignment_per_s = kAlignmentFraction / controller_.config().steering_time_constant_s;
      for (std::size_t i = 0; i < 2; ++i) {
        const double error = 0.5 * WrapAngle(2.0 * (psi - seen.pose.angle_rad - seen.steer_rad[i]));
        const double rate = last_control_.commanded_rate_rad_per_s - omega + alignment_per_s * error;
        in.steering_torque_Nm[i] = k2 * (rate - state_.steer_rate_rad_per_s[i]);
      }
    }
  }
  Step(config_.bicycle, in, period_s, state_);
  time_s_ += period_s;
}

void BicycleCobotDevice::SetSafe() noexcept {
  safe_ = true;
  locked_ = walls_.source() < 0;  // near a fixture: keep steering against the last wall (as the unicycle)
}

// ---------------------------------------------------------------- registration

DeviceBackend CobotBackend() {
  DeviceBackend b;
  b.name = kName;
  b.description =
      "cobot (Colgate et al.): a steered wheel renders walls passively; unicycle (x, y) or bicycle (x, y, θ), "
      "simulated or (unicycle) on CAN";
  b.nominal = CobotCapabilities(2, 0.0);
  b.keys = {
      {"kind", "unicycle (dof 2, default) or bicycle (dof 3; walls on the plate's reference point)"},
      {"cart_mass_kg", "moving mass (kg), > 0; default 10"},
      {"rolling_damping_Ns_per_m", "rolling resistance (N·s/m), >= 0; default 20"},
      {"steering_inertia_kgm2", "wheel assembly about the steering axis (kg·m²), > 0; default 0.002"},
      {"steering_damping_Nms_per_rad", "steering friction b (N·m·s/rad), >= 0; default 0.004"},
      {"max_steering_torque_Nm", "steering motor limit (N·m), > 0; default 2"},
      {"cornering_stiffness_N_per_rad", "wheel slip model C (N/rad), >= 0, 0 = no slip; default 500"},
      {"brake_max_force_N", "wheel brake (N), >= 0, 0 = none; default 0"},
      {"friction_coefficient",
       "tire μ: the floor carries at most μ·N across the wheel, then it slides; >= 0, "
       "0 = no limit; default 0 (unicycle)"},
      {"normal_load_N", "N of the friction limit (N), >= 0, 0 = cart_mass_kg·g; default 0"},
      {"wheel_radius_m", "wheel radius (m), > 0; default 0.05"},
      {"wheel_encoder_counts_per_rev", "wheel encoder counts, >= 0 (0 = ideal); default 16384"},
      {"steering_encoder_counts_per_rev", "steering encoder counts, >= 0 (0 = ideal); default 16384"},
      {"position_resolution_m", "absolute position sensing step (m), >= 0; default 1e-5"},
      {"force_resolution_N", "handle force sensor step (N), >= 0; default 0.01"},
      {"steering_time_constant_s", "tau of the steering-velocity loop (eq 3c), sets K2 = J/tau - b; default 0.02"},
      {"virtual_mass_kg",
       "1/K1 of the virtual caster (eq 2) (kg), > 0; default 10 (unicycle only: the bicycle's is "
       "its plate mass)"},
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
      {"bicycle.plate_mass_kg", "plate mass (kg), > 0; also the caster's virtual mass (isotropic); default 12"},
      {"bicycle.plate_inertia_kgm2", "plate inertia (kg·m²), > 0; also the caster's virtual inertia; default 0.4"},
      {"bicycle.singularity_threshold", "singularity measure below which the guard acts, 0..0.99; default 0.05"},
      {"bicycle.singularity_guard", "keep the wheels off the singular configuration; default true"},
      {"bicycle.hold_heading_deg", "angular constraint: the wheels hold the plate's θ at this (deg); default none"},
      {"bicycle.heading_bandwidth_per_s", "ω_h of the angular constraint's return (rad/s), 0.1..20; default 5"},
      {"rig", "simulated (default: the models above) or fieldbus (the real unicycle cobot on CAN, needs fieldbus)"},
      {"fieldbus", "the real rig's CAN bus, steering drive and sensor node (rig: fieldbus only)"},
      {"fieldbus.can", "the bus: medium, interface or bus"},
      {"fieldbus.can.medium", "socketcan (default) or emulated (the teleop-canbus daemon)"},
      {"fieldbus.can.interface", "SocketCAN interface (can0, vcan0, ...); required for socketcan"},
      {"fieldbus.can.bus", "teleop-canbus address IPv4:PORT (emulated only); default 127.0.0.1:47300"},
      {"fieldbus.can.connect_timeout_ms", "how long to wait for teleop-canbus (ms), > 0; default 1000"},
      {"fieldbus.cycle_period_ms", "SYNC period written to the drive (ms), 0.125..100, = 1000/rate_hz; default 1"},
      {"fieldbus.first_frames_timeout_ms",
       "activation: wait for the drive's and sensor node's first PDOs (ms); "
       "default 500"},
      {"fieldbus.steering", "the steering motor's CiA 402 drive (cyclic synchronous torque)"},
      {"fieldbus.steering.node_id", "CANopen node id, 1..127; required"},
      {"fieldbus.steering.mode", "torque (cyclic synchronous torque; velocity is refused: the client has no CSV)"},
      {"fieldbus.steering.gear_ratio", "motor rad per steering rad, > 0; default 1"},
      {"fieldbus.steering.position_rad_per_count", "motor rad per position-actual unit (0x6064), > 0; default 1/4096"},
      {"fieldbus.steering.velocity_rad_per_s_per_unit",
       "motor rad/s per velocity-actual unit (0x606C), > 0; "
       "default 1/4096"},
      {"fieldbus.steering.direction", "1 or -1: the drive's positive direction against the steering angle's"},
      {"fieldbus.steering.rated_torque_Nm", "the drive's rated torque 0x6076 (N·m, motor side), checked; default 1"},
      {"fieldbus.steering.max_torque_Nm", "torque limit written to 0x6072 (N·m, motor side), > 0; default 0.5"},
      {"fieldbus.steering.offset_deg", "cart heading when the steering angle reads 0 (deg); default 0"},
      {"fieldbus.steering.max_angle_jump_rad",
       "steering angle step per cycle that is an encoder jump (rad); "
       "default 0.2"},
      {"fieldbus.steering.hold_stiffness_Nm_per_rad", "hold after an encoder jump (N·m/rad, motor side); default 2"},
      {"fieldbus.steering.hold_damping_Nms_per_rad", "hold damping (N·m·s/rad, motor side), >= 0; default 0.05"},
      {"fieldbus.steering.heartbeat_period_ms", "the drive's heartbeat period 0x1017 (ms); default 50"},
      {"fieldbus.steering.heartbeat_timeout_ms",
       "heartbeat consumer timeout (ms), > heartbeat_period_ms; "
       "default 150"},
      {"fieldbus.steering.stale_after_ms", "no TPDO for this long: the drive is lost (ms); default 10"},
      {"fieldbus.sensors", "the wheel encoder, handle force sensor and wheel brake on a separate CAN node"},
      {"fieldbus.sensors.source",
       "node (a separate CAN node; drive is refused: the drive's PDOs carry the steering "
       "axis only)"},
      {"fieldbus.sensors.node_id", "the sensor node's id, 1..127, not the drive's; required"},
      {"fieldbus.sensors.wheel_cob_id", "wheel TPDO COB-ID (INTEGER32 counts, CiA 406 0x6004); default 0x180+node"},
      {"fieldbus.sensors.force_cob_id",
       "force TPDO COB-ID (2 x INTEGER16, CiA 401 0x6401/1-2, 0x8000 = invalid); default 0x280+node"},
      {"fieldbus.sensors.brake_cob_id",
       "brake RPDO COB-ID (1 byte, bit 0, CiA 401 0x6200/1), used when "
       "brake_max_force_N > 0; default 0x200+node"},
      {"fieldbus.sensors.wheel_direction", "1 or -1: the wheel encoder's count direction; default 1"},
      {"fieldbus.sensors.force_N_per_unit", "handle force scaling (N per analog unit), > 0; default 0.01"},
      {"fieldbus.sensors.stale_after_ms", "no sensor TPDO for this long: the node is lost (ms); default 10"},
      {"fieldbus.sensors.max_wheel_step_m",
       "wheel travel step between two TPDOs that is an encoder jump (m); "
       "default 0.01"},
  };
  b.section_required = false;
  b.read = [](const Field* section, const SectionContext& context) -> std::any {
    return ReadCobot(section, context.dof, context.role);
  };
  b.make = [](const DeviceConfig& config) -> std::unique_ptr<Device> {
    const CobotBackendConfig c = config.section.has_value() ? config.Section<CobotBackendConfig>()
                                                            : ReadCobot(nullptr, config.dof, Role::kMaster);
    const int expected = c.kind == CobotBackendConfig::Kind::kUnicycle ? 2 : 3;
    if (config.dof != expected) {
      throw Error("device.cobot: this cobot has dof " + std::to_string(expected) + ", the process " +
                  std::to_string(config.dof));
    }
    if (c.kind == CobotBackendConfig::Kind::kBicycle) return std::make_unique<BicycleCobotDevice>(c);
    if (c.rig == CobotBackendConfig::Rig::kFieldbus) return std::make_unique<UnicycleCobotFieldbusDevice>(c);
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
