// The `hybrid` backend: the Kwon & Song motor–brake five-bar, simulated (docs/hybrid.md, `device.hybrid`).
#include "device/hybrid/hybrid_backend.hpp"

#include <Eigen/LU>
#include <memory>

#include "device/hybrid/hybrid_fieldbus_section.hpp"
#include "device/hybrid/hybrid_keys.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/backend_key_table.hpp"

namespace teleop::device::hybrid {
namespace {

using config::Field;
using config::Finite;
using config::Map;
using config::NonNegative;
using config::Positive;

Eigen::Vector2d Vec2(const Field& f) {
  const DofVector v = config::ReadDofVector(f, 2, Finite);
  return {v(0), v(1)};
}

Eigen::Vector2d Unit2(const Field& f) {
  const Eigen::Vector2d v = Vec2(f);
  if (!(v.norm() > 0.0)) f.Fail("must be a non-zero direction");
  return v.normalized();
}

void ReadGeometry(const Field& f, FiveBarConfig& g) {
  const Map m(f, {"proximal_1_m", "proximal_2_m", "distal_1_m", "distal_2_m", "base_separation_m", "joint_1_min_deg",
                  "joint_1_max_deg", "joint_2_min_deg", "joint_2_max_deg", "workspace_x_m", "workspace_y_m"});
  if (auto v = m.Optional("proximal_1_m")) g.proximal_1_m = Positive(*v, "m");
  if (auto v = m.Optional("proximal_2_m")) g.proximal_2_m = Positive(*v, "m");
  if (auto v = m.Optional("distal_1_m")) g.distal_1_m = Positive(*v, "m");
  if (auto v = m.Optional("distal_2_m")) g.distal_2_m = Positive(*v, "m");
  if (auto v = m.Optional("base_separation_m")) g.base_separation_m = NonNegative(*v, "m");
  if (auto v = m.Optional("joint_1_min_deg")) g.joint_1_min_rad = Finite(*v) * config::kDeg;
  if (auto v = m.Optional("joint_1_max_deg")) g.joint_1_max_rad = Finite(*v) * config::kDeg;
  if (auto v = m.Optional("joint_2_min_deg")) g.joint_2_min_rad = Finite(*v) * config::kDeg;
  if (auto v = m.Optional("joint_2_max_deg")) g.joint_2_max_rad = Finite(*v) * config::kDeg;
  if (auto v = m.Optional("workspace_x_m")) {
    const Eigen::Vector2d r = Vec2(*v);
    g.workspace_x_min_m = r.x();
    g.workspace_x_max_m = r.y();
  }
  if (auto v = m.Optional("workspace_y_m")) {
    const Eigen::Vector2d r = Vec2(*v);
    g.workspace_y_min_m = r.x();
    g.workspace_y_max_m = r.y();
  }
}

void ReadWall(const Map& m, WallConfig& w) {
  if (auto v = m.Optional("model")) {
    if (!ParseWallKind(v->AsString().c_str(), w.kind)) v->Fail("must be spring, popc, hybrid or linear-damper");
  }
  if (auto v = m.Optional("point_m")) w.point_m = Vec2(*v);
  if (auto v = m.Optional("normal")) w.normal = Unit2(*v);
  if (auto v = m.Optional("stiffness_N_per_m")) w.stiffness_N_per_m = NonNegative(*v, "N/m");
  if (auto v = m.Optional("damper_coefficient")) w.damper_coefficient = NonNegative(*v, "N·s³/m³");
  if (auto v = m.Optional("max_force_N")) w.max_force_N = Positive(*v, "N");
}

void ReadEffect(const Field& f, HybridEffectConfig& e) {
  const Field type_field =
      config::TypeOf(f, {"type", "model", "display", "point_m", "normal", "stiffness_N_per_m", "damper_coefficient",
                         "max_force_N", "static_coefficient", "kinetic_coefficient"});
  const std::string type = type_field.AsString();
  if (type == "none") {
    const Map m(f, {"type"});
    e.kind = HybridEffectConfig::Kind::kNone;
  } else if (type == "wall") {
    const Map m(f, {"type", "model", "point_m", "normal", "stiffness_N_per_m", "damper_coefficient", "max_force_N"});
    e.kind = HybridEffectConfig::Kind::kWall;
    ReadWall(m, e.wall);
  } else if (type == "friction") {
    const Map m(
        f, {"type", "display", "point_m", "normal", "stiffness_N_per_m", "static_coefficient", "kinetic_coefficient"});
    e.kind = HybridEffectConfig::Kind::kFriction;
    FrictionConfig& fr = e.friction;
    if (auto v = m.Optional("display")) {
      if (!ParseFrictionDisplay(v->AsString().c_str(), fr.display)) v->Fail("must be motor or brake");
    }
    if (auto v = m.Optional("point_m")) fr.point_m = Vec2(*v);
    if (auto v = m.Optional("normal")) fr.normal = Unit2(*v);
    if (auto v = m.Optional("stiffness_N_per_m")) fr.stiffness_N_per_m = NonNegative(*v, "N/m");
    if (auto v = m.Optional("static_coefficient")) fr.static_coefficient = NonNegative(*v, "");
    if (auto v = m.Optional("kinetic_coefficient")) fr.kinetic_coefficient = NonNegative(*v, "");
    if (fr.kinetic_coefficient > fr.static_coefficient)
      f.Fail("kinetic_coefficient must not exceed static_coefficient");
  } else {
    type_field.Fail("must be none, wall or friction; got '" + type + "'");
  }
}

HybridDeviceConfig ReadHybrid(const Field* section) {
  HybridDeviceConfig c;
  if (section == nullptr) return c;
  const Map m(*section, {"initial_position_m", "geometry", "motor", "brake", "joint_inertia_kgm2", "handle_mass_kg",
                         "joint_damping_Nms_per_rad", "joint_coulomb_Nm", "substeps", "allocation", "effect",
                         "operator", "environment", "rig", "fieldbus", "encoders", "force_sensor"});
  c.fieldbus_rig = config::ReadChoice(m, keys::kRigKind) == 1;
  if (c.fieldbus_rig) {
    // The simulation's own inputs make no sense on the real rig: refuse them rather than ignore them.
    for (const char* key : {"operator", "environment", "effect", "substeps", "encoders", "force_sensor"}) {
      if (auto v = m.Optional(key)) v->Fail("is for the simulated rig; remove it with rig: fieldbus");
    }
    (void)m.Required("fieldbus");
  } else if (auto v = m.Optional("fieldbus")) {
    v->Fail("is read only with rig: fieldbus (set device.hybrid.rig: fieldbus, or remove it)");
  }
  if (auto v = m.Optional("initial_position_m")) c.rig.initial_position_m = Vec2(*v);
  if (auto v = m.Optional("geometry")) ReadGeometry(*v, c.rig.geometry);
  if (auto v = m.Optional("motor")) {
    const Map mm(*v, {"max_torque_Nm", "time_constant_s", "pulley_ratio"});
    c.rig.motor.max_torque_Nm = config::ReadNumber(mm, keys::kMotorMaxTorque);
    c.rig.motor.time_constant_s = config::ReadNumber(mm, keys::kMotorTimeConstant);
    c.rig.motor.pulley_ratio = config::ReadNumber(mm, keys::kMotorPulleyRatio);
  }
  if (auto v = m.Optional("brake")) {
    const Map mm(*v, {"max_torque_Nm", "time_constant_s", "drag_Nm", "hysteresis_Nm", "pulley_ratio",
                      "residual_fraction", "static_ratio"});
    c.rig.brake.residual_fraction = config::ReadNumber(mm, keys::kBrakeResidual);
    c.rig.brake.static_ratio = config::ReadNumber(mm, keys::kBrakeStaticRatio);
    c.rig.brake.max_torque_Nm = config::ReadNumber(mm, keys::kBrakeMaxTorque);
    c.rig.brake.time_constant_s = config::ReadNumber(mm, keys::kBrakeTimeConstant);
    c.rig.brake.drag_Nm = config::ReadNumber(mm, keys::kBrakeDrag);
    c.rig.brake.hysteresis_Nm = config::ReadNumber(mm, keys::kBrakeHysteresis);
    c.rig.brake.pulley_ratio = config::ReadNumber(mm, keys::kBrakePulleyRatio);
  }
  c.rig.joint_inertia_kgm2 = config::ReadNumber(m, keys::kJointInertia);
  c.rig.handle_mass_kg = config::ReadNumber(m, keys::kHandleMass);
  c.rig.joint_damping_Nms_per_rad = config::ReadNumber(m, keys::kJointDamping);
  c.rig.substeps = config::ReadInteger(m, keys::kSubsteps);
  c.rig.joint_coulomb_Nm = config::ReadNumber(m, keys::kJointCoulomb);
  if (auto v = m.Optional("encoders")) {
    const Map mm(*v, {"counts_per_joint_rev", "velocity_filter_hz"});
    c.rig.encoders.counts_per_joint_rev = config::ReadNumber(mm, keys::kEncoderCounts);
    c.rig.encoders.velocity_filter_hz = config::ReadNumber(mm, keys::kEncoderVelocityFilter);
  }
  if (auto v = m.Optional("force_sensor")) {
    const Map mm(*v, {"noise_std_N", "bandwidth_hz", "seed"});
    c.rig.force_sensor_dynamics.noise_std_N = config::ReadNumber(mm, keys::kForceSensorNoise);
    c.rig.force_sensor_dynamics.bandwidth_hz = config::ReadNumber(mm, keys::kForceSensorBandwidth);
    c.rig.force_sensor_dynamics.seed = static_cast<std::uint64_t>(config::ReadInteger(mm, keys::kForceSensorSeed));
  }
  if (auto v = m.Optional("allocation")) {
    const Map mm(*v, {"use_brakes", "rest_velocity_rad_per_s", "brake_model_mismatch"});
    c.allocation.brake_model_mismatch = config::ReadNumber(mm, keys::kAllocationBrakeMismatch);
    c.allocation.use_brakes = config::ReadBool(mm, keys::kAllocationUseBrakes);
    c.allocation.rest_velocity_rad_per_s = config::ReadNumber(mm, keys::kAllocationRestVelocity);
  }
  if (auto v = m.Optional("effect")) ReadEffect(*v, c.effect);
  if (auto v = m.Optional("operator")) {
    const Map mm(*v, {"direction", "speed_m_per_s", "travel_m", "stiffness_N_per_m", "damping_Ns_per_m", "max_force_N",
                      "mass_kg"});
    c.simulated_operator = true;
    if (auto x = mm.Optional("direction")) c.hand.direction = Unit2(*x);
    if (auto x = mm.Optional("speed_m_per_s")) c.hand.speed_m_per_s = NonNegative(*x, "m/s");
    if (auto x = mm.Optional("travel_m")) c.hand.travel_m = NonNegative(*x, "m");
    if (auto x = mm.Optional("stiffness_N_per_m")) c.hand.stiffness_N_per_m = NonNegative(*x, "N/m");
    if (auto x = mm.Optional("damping_Ns_per_m")) c.hand.damping_Ns_per_m = NonNegative(*x, "N·s/m");
    if (auto x = mm.Optional("max_force_N")) c.hand.max_force_N = NonNegative(*x, "N");
    if (auto x = mm.Optional("mass_kg")) c.hand_mass_kg = NonNegative(*x, "kg");
  }
  if (auto v = m.Optional("environment")) {
    const Map mm(*v, {"point_m", "normal", "stiffness_N_per_m", "damping_Ns_per_m"});
    c.environment.wall = true;
    c.environment.point_m = Vec2(mm.Required("point_m"));
    if (auto x = mm.Optional("normal")) c.environment.normal = Unit2(*x);
    c.environment.stiffness_N_per_m = Positive(mm.Required("stiffness_N_per_m"), "N/m");
    if (auto x = mm.Optional("damping_Ns_per_m")) c.environment.damping_Ns_per_m = NonNegative(*x, "N·s/m");
  }
  try {
    c.Validate();
  } catch (const Error& e) {
    section->Fail(e.what());
  }
  if (c.fieldbus_rig) {
    HybridFieldbusConfig& d = c.fieldbus.device;
    d.geometry = c.rig.geometry;
    d.allocation = c.allocation;
    d.allocation.motor = c.rig.motor;
    d.allocation.brake = c.rig.brake;
    d.origin_m = c.rig.initial_position_m;
    ReadHybridFieldbusSection(m.Required("fieldbus"), c.fieldbus);
  }
  return c;
}

}  // namespace

DeviceBackend HybridBackend() {
  DeviceBackend b;
  b.name = "hybrid";
  b.description =
      "2-DOF five-bar with a motor and a particle brake per joint, Kwon & Song: simulated, or the real rig over "
      "CiA 402 + Modbus (rig: fieldbus; docs/hybrid.md)";
  b.nominal.dof = 2;
  b.nominal.rendering = Rendering::kActiveAndDissipative;
  b.nominal.has_brake = true;
  b.nominal.measures_velocity = true;
  b.nominal.measures_force = true;
  b.keys = {
      {"initial_position_m", "handle start [x, y] (m, base frame); readings are relative to it; default [0, 0.2]"},
      {"geometry",
       "five-bar: proximal_1_m, proximal_2_m, distal_1_m, distal_2_m (0.2), base_separation_m (0), "
       "joint_1_min_deg/max (-40/110), joint_2_min_deg/max (70/220), workspace_x_m [-0.19, 0.19], "
       "workspace_y_m [0.09, 0.32]"},
      {"motor", "the motor per joint: the motor.* keys"},
      {"brake", "the particle brake per joint: the brake.* keys"},
      {"encoders", "the simulated rig's encoders: the encoders.* keys"},
      {"force_sensor", "the simulated handle sensor: the force_sensor.* keys"},
      {"allocation", "the motor/brake torque allocation: the allocation.* keys"},
      {"effect",
       "local haptic effect: type none | wall (model spring|popc|hybrid|linear-damper, point_m, normal, "
       "stiffness_N_per_m, damper_coefficient, max_force_N) | friction (display motor|brake, point_m, "
       "normal, stiffness_N_per_m, static_coefficient, kinetic_coefficient)"},
      {"operator",
       "simulated hand (master): direction, speed_m_per_s, travel_m, stiffness_N_per_m, damping_Ns_per_m, "
       "max_force_N, mass_kg"},
      {"environment", "simulated wall on the handle (slave): point_m, normal, stiffness_N_per_m, damping_Ns_per_m"},
  };
  AdoptKeyTable(b, keys::All());  // the keys with a number or a word, written once (hybrid_keys.hpp)
  for (ConfigKey& key : HybridFieldbusKeys()) b.keys.push_back(std::move(key));
  b.section_required = false;
  b.read = [](const Field* section, const SectionContext& context) -> std::any {
    if (context.dof != 2) {
      if (section != nullptr) section->Fail("the hybrid device has 2 DOF; set dof: 2");
      throw Error("device.hybrid: the hybrid device has 2 DOF; set dof: 2");
    }
    return ReadHybrid(section);
  };
  b.make = [](const DeviceConfig& config) -> std::unique_ptr<Device> {
    if (config.dof != 2) throw Error("device.hybrid: the hybrid device has 2 DOF; set dof: 2");
    const HybridDeviceConfig c =
        config.section.has_value() ? config.Section<HybridDeviceConfig>() : HybridDeviceConfig{};
    if (c.fieldbus_rig) return std::make_unique<HybridFieldbusDevice>(c.fieldbus.device, c.fieldbus.can);
    return std::make_unique<HybridDevice>(c);
  };
  b.model = [](const DeviceConfig& config) {
    const HybridDeviceConfig c =
        config.section.has_value() ? config.Section<HybridDeviceConfig>() : HybridDeviceConfig{};
    // Effective handle mass Λ = (J M⁻¹ Jᵀ)⁻¹ and damping J⁻ᵀ B J⁻¹ at the initial position, diagonal per axis.
    const FiveBar fb(c.rig.geometry);
    Eigen::Vector2d q;
    Eigen::Matrix2d jac;
    if (!fb.Inverse(c.rig.initial_position_m, q) || !fb.Jacobian(q, jac)) {
      return AnalysisModel::NotApplicable("the initial position has no Jacobian");
    }
    const double handle = c.rig.handle_mass_kg + c.hand_mass_kg;
    const Eigen::Matrix2d m = c.rig.joint_inertia_kgm2 * Eigen::Matrix2d::Identity() + handle * jac.transpose() * jac;
    const Eigen::Matrix2d lambda = (jac * m.inverse() * jac.transpose()).inverse();
    const Eigen::Matrix2d jinv = jac.inverse();
    const Eigen::Matrix2d damping = c.rig.joint_damping_Nms_per_rad * jinv.transpose() * jinv;
    AnalysisModel model;
    model.mass_kg = DofVector::Zero(2);
    model.damping_Ns_per_m = DofVector::Zero(2);
    for (int i = 0; i < 2; ++i) {
      model.mass_kg(i) = lambda(i, i);
      model.damping_Ns_per_m(i) = damping(i, i);
    }
    return model;
  };
  return b;
}

DeviceConfig HybridDeviceConfigOf(const HybridDeviceConfig& config) { return DeviceConfig::Of("hybrid", 2, config); }

}  // namespace teleop::device::hybrid

TELEOP_REGISTER_DEVICE(hybrid, teleop::device::hybrid::HybridBackend())
