// The `hybrid` backend: the Kwon & Song motor–brake five-bar, simulated (docs/hybrid.md, `device.hybrid`).
#include "device/hybrid/hybrid_backend.hpp"

#include <Eigen/LU>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "device/hybrid/hybrid_fieldbus_section.hpp"
#include "device/hybrid/hybrid_keys.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/backend_key_table.hpp"

namespace teleop::device::hybrid {
namespace {

using config::Field;
using config::KeysUnder;
using config::Map;
using config::ReadDirection;
using config::ReadNumber;
using config::ReadPair;

/// The keys of `device.hybrid.<section>` (`prefix` "geometry."), as its table lists them.
Map SectionMap(const Field& f, std::string_view prefix, std::string_view type = "") {
  return Map(f, KeysUnder(keys::All(), prefix, type));
}

void ReadGeometry(const Field& f, FiveBarConfig& g) {
  const Map m = SectionMap(f, "geometry.");
  g.proximal_1_m = ReadNumber(m, keys::kProximal1);
  g.proximal_2_m = ReadNumber(m, keys::kProximal2);
  g.distal_1_m = ReadNumber(m, keys::kDistal1);
  g.distal_2_m = ReadNumber(m, keys::kDistal2);
  g.base_separation_m = ReadNumber(m, keys::kBaseSeparation);
  g.joint_1_min_rad = ReadNumber(m, keys::kJoint1Min) * config::kDeg;
  g.joint_1_max_rad = ReadNumber(m, keys::kJoint1Max) * config::kDeg;
  g.joint_2_min_rad = ReadNumber(m, keys::kJoint2Min) * config::kDeg;
  g.joint_2_max_rad = ReadNumber(m, keys::kJoint2Max) * config::kDeg;
  const Eigen::Vector2d x = ReadPair(m, keys::kWorkspaceX);
  const Eigen::Vector2d y = ReadPair(m, keys::kWorkspaceY);
  g.workspace_x_min_m = x.x();
  g.workspace_x_max_m = x.y();
  g.workspace_y_min_m = y.x();
  g.workspace_y_max_m = y.y();
}

void ReadEffect(const Field& f, HybridEffectConfig& e) {
  // The type first, among the keys of every type; then the keys of this type only.
  e.kind = config::ReadChoiceAs<HybridEffectConfig::Kind>(SectionMap(f, "effect.", "*"), keys::kEffectType);
  const Map m = SectionMap(f, "effect.", keys::kEffectType.choices[static_cast<std::size_t>(e.kind)]);
  if (e.kind == HybridEffectConfig::Kind::kWall) {
    WallConfig& w = e.wall;
    w.kind = config::ReadChoiceAs<WallKind>(m, keys::kWallModel);
    w.point_m = ReadPair(m, keys::kWallPoint);
    w.normal = ReadDirection(m, keys::kWallNormal);
    w.stiffness_N_per_m = ReadNumber(m, keys::kWallStiffness);
    w.damper_coefficient = ReadNumber(m, keys::kWallDamper);
    w.max_force_N = ReadNumber(m, keys::kWallMaxForce);
  } else if (e.kind == HybridEffectConfig::Kind::kFriction) {
    FrictionConfig& fr = e.friction;
    fr.display = config::ReadChoiceAs<FrictionDisplay>(m, keys::kFrictionDisplay);
    fr.point_m = ReadPair(m, keys::kFrictionPoint);
    fr.normal = ReadDirection(m, keys::kFrictionNormal);
    fr.stiffness_N_per_m = ReadNumber(m, keys::kFrictionStiffness);
    fr.static_coefficient = ReadNumber(m, keys::kFrictionStatic);
    fr.kinetic_coefficient = ReadNumber(m, keys::kFrictionKinetic);
    if (fr.kinetic_coefficient > fr.static_coefficient)
      f.Fail("kinetic_coefficient must not exceed static_coefficient");
  }
}

void ReadOperator(const Field& f, HybridDeviceConfig& c) {
  const Map m = SectionMap(f, "operator.");
  c.simulated_operator = true;
  c.hand.direction = ReadDirection(m, keys::kHandDirection);
  c.hand.speed_m_per_s = ReadNumber(m, keys::kHandSpeed);
  c.hand.travel_m = ReadNumber(m, keys::kHandTravel);
  c.hand.stiffness_N_per_m = ReadNumber(m, keys::kHandStiffness);
  c.hand.damping_Ns_per_m = ReadNumber(m, keys::kHandDamping);
  c.hand.max_force_N = ReadNumber(m, keys::kHandMaxForce);
  c.hand_mass_kg = ReadNumber(m, keys::kHandMass);
}

void ReadEnvironment(const Field& f, HybridEnvironmentConfig& env) {
  const Map m = SectionMap(f, "environment.");
  env.wall = true;
  env.point_m = ReadPair(m, keys::kEnvironmentPoint);
  env.normal = ReadDirection(m, keys::kEnvironmentNormal);
  env.stiffness_N_per_m = ReadNumber(m, keys::kEnvironmentStiffness);
  env.damping_Ns_per_m = ReadNumber(m, keys::kEnvironmentDamping);
}

/// The rig's simulated parts that have a section: motor, brake, encoders, force sensor (each optional).
void ReadRigSections(const Map& m, HybridRigConfig& rig) {
  if (auto v = m.Optional(keys::kMotorSection.key)) {
    const Map mm = SectionMap(*v, "motor.");
    rig.motor.max_torque_Nm = ReadNumber(mm, keys::kMotorMaxTorque);
    rig.motor.time_constant_s = ReadNumber(mm, keys::kMotorTimeConstant);
    rig.motor.pulley_ratio = ReadNumber(mm, keys::kMotorPulleyRatio);
  }
  if (auto v = m.Optional(keys::kBrakeSection.key)) {
    const Map mm = SectionMap(*v, "brake.");
    rig.brake.residual_fraction = ReadNumber(mm, keys::kBrakeResidual);
    rig.brake.static_ratio = ReadNumber(mm, keys::kBrakeStaticRatio);
    rig.brake.max_torque_Nm = ReadNumber(mm, keys::kBrakeMaxTorque);
    rig.brake.time_constant_s = ReadNumber(mm, keys::kBrakeTimeConstant);
    rig.brake.drag_Nm = ReadNumber(mm, keys::kBrakeDrag);
    rig.brake.hysteresis_Nm = ReadNumber(mm, keys::kBrakeHysteresis);
    rig.brake.pulley_ratio = ReadNumber(mm, keys::kBrakePulleyRatio);
  }
  if (auto v = m.Optional(keys::kEncodersSection.key)) {
    const Map mm = SectionMap(*v, "encoders.");
    rig.encoders.counts_per_joint_rev = ReadNumber(mm, keys::kEncoderCounts);
    rig.encoders.velocity_filter_hz = ReadNumber(mm, keys::kEncoderVelocityFilter);
  }
  if (auto v = m.Optional(keys::kForceSensorSection.key)) {
    const Map mm = SectionMap(*v, "force_sensor.");
    rig.force_sensor_dynamics.noise_std_N = ReadNumber(mm, keys::kForceSensorNoise);
    rig.force_sensor_dynamics.bandwidth_hz = ReadNumber(mm, keys::kForceSensorBandwidth);
    rig.force_sensor_dynamics.seed = static_cast<std::uint64_t>(config::ReadInteger(mm, keys::kForceSensorSeed));
  }
}

/// rig: fieldbus takes a fieldbus section and refuses the simulation's own inputs; rig: simulated the other way.
void CheckRigKind(const Map& m, bool fieldbus_rig) {
  if (fieldbus_rig) {
    for (const config::KeySpec* spec : {&keys::kOperatorSection, &keys::kEnvironmentSection, &keys::kEffectSection,
                                        &keys::kSubsteps, &keys::kEncodersSection, &keys::kForceSensorSection}) {
      if (auto v = m.Optional(spec->key)) v->Fail("is for the simulated rig; remove it with rig: fieldbus");
    }
    (void)m.Required(keys::kFieldbusSection.key);
  } else if (auto v = m.Optional(keys::kFieldbusSection.key)) {
    v->Fail("is read only with rig: fieldbus (set device.hybrid.rig: fieldbus, or remove it)");
  }
}

HybridDeviceConfig ReadHybrid(const Field* section) {
  HybridDeviceConfig c;
  if (section == nullptr) return c;
  const Map m = SectionMap(*section, "");
  c.fieldbus_rig = config::ReadChoice(m, keys::kRigKind) == 1;
  CheckRigKind(m, c.fieldbus_rig);
  c.rig.initial_position_m = ReadPair(m, keys::kInitialPosition);
  if (auto v = m.Optional(keys::kGeometrySection.key)) ReadGeometry(*v, c.rig.geometry);
  ReadRigSections(m, c.rig);
  c.rig.joint_inertia_kgm2 = ReadNumber(m, keys::kJointInertia);
  c.rig.handle_mass_kg = ReadNumber(m, keys::kHandleMass);
  c.rig.joint_damping_Nms_per_rad = ReadNumber(m, keys::kJointDamping);
  c.rig.substeps = config::ReadInteger(m, keys::kSubsteps);
  c.rig.joint_coulomb_Nm = ReadNumber(m, keys::kJointCoulomb);
  if (auto v = m.Optional(keys::kAllocationSection.key)) {
    const Map mm = SectionMap(*v, "allocation.");
    c.allocation.brake_model_mismatch = ReadNumber(mm, keys::kAllocationBrakeMismatch);
    c.allocation.use_brakes = config::ReadBool(mm, keys::kAllocationUseBrakes);
    c.allocation.rest_velocity_rad_per_s = ReadNumber(mm, keys::kAllocationRestVelocity);
  }
  if (auto v = m.Optional(keys::kEffectSection.key)) ReadEffect(*v, c.effect);
  if (auto v = m.Optional(keys::kOperatorSection.key)) ReadOperator(*v, c);
  if (auto v = m.Optional(keys::kEnvironmentSection.key)) ReadEnvironment(*v, c.environment);
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
    ReadHybridFieldbusSection(m.Required(keys::kFieldbusSection.key), c.fieldbus);
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
  AdoptKeyTable(b, keys::All());  // every key but fieldbus.*, written once (hybrid_keys.hpp)
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
