// The `arm` backend: a URDF arm behind the joint-actuator seam (docs/arms.md; docs/configuration.md, `device.arm`).

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "arm_keys.hpp"
#include "arm_section.hpp"
#include "simulated_cia402_arm.hpp"
#include "simulated_mit_arm.hpp"
#include "teleop/config/key_table.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/backend_key_table.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/can_port_yaml.hpp"
#include "teleop/fieldbus/mit_motor_models.hpp"

namespace teleop::device::arm {
namespace {

using config::Field;
using config::Map;

std::vector<double> ReadList(const Field& f, const char* unit) {
  std::vector<double> values;
  for (const Field& item : f.AsList()) {
    values.push_back(config::Finite(item));
    (void)unit;
  }
  return values;
}

JointLimitOverride ReadLimit(const Field& f) {
  const Map map(f, {"joint", "lower_rad", "upper_rad", "max_velocity_rad_per_s", "max_effort_Nm"});
  JointLimitOverride o;
  o.joint = map.Required("joint").AsString();
  if (auto v = map.Optional("lower_rad")) o.lower = config::Finite(*v);
  if (auto v = map.Optional("upper_rad")) o.upper = config::Finite(*v);
  if (auto v = map.Optional("max_velocity_rad_per_s")) o.max_velocity = config::Positive(*v, "rad/s");
  if (auto v = map.Optional("max_effort_Nm")) o.max_effort = config::Positive(*v, "N·m");
  return o;
}

Eigen::Vector3d ToVector3(const DofVector& v) { return {v[0], v[1], v[2]}; }

void ReadSimulation(const Field& f, SimulatedArmConfig& sim, std::vector<double>& initial_q) {
  namespace k = arm_keys;
  const Map map(f, {"initial_q_rad", "viscous_Nms_per_rad", "coulomb_Nm", "encoder_resolution_rad", "substeps",
                    "stop_stiffness_Nm_per_rad", "stop_damping_Nms_per_rad", "hand_mass_kg", "hand_damping_Ns_per_m",
                    "hand_stiffness_N_per_m", "hand_push_N", "hand_push_start_s", "environment_normal",
                    "environment_offset_m", "environment_stiffness_N_per_m", "environment_damping_Ns_per_m"});
  if (auto v = map.Optional("initial_q_rad")) initial_q = ReadList(*v, "rad");
  sim.viscous_Nms_per_rad = config::ReadNumber(map, k::kSimViscous);
  sim.coulomb_Nm = config::ReadNumber(map, k::kSimCoulomb);
  sim.encoder_resolution_rad = config::ReadNumber(map, k::kSimEncoder);
  sim.substeps = config::ReadInteger(map, k::kSimSubsteps);
  sim.stop_stiffness_Nm_per_rad = config::ReadNumber(map, k::kSimStopStiffness);
  sim.stop_damping_Nms_per_rad = config::ReadNumber(map, k::kSimStopDamping);
  sim.hand_mass_kg = config::ReadNumber(map, k::kSimHandMass);
  sim.hand_damping_Ns_per_m = config::ReadNumber(map, k::kSimHandDamping);
  sim.hand_stiffness_N_per_m = config::ReadNumber(map, k::kSimHandStiffness);
  sim.hand_push_N = ToVector3(config::ReadDofValue(map, k::kSimHandPush, 3));
  sim.hand_push_start_s = config::ReadNumber(map, k::kSimHandPushStart);
  const Eigen::Vector3d normal = ToVector3(config::ReadDofValue(map, k::kSimEnvNormal, 3));
  sim.environment = normal.norm() > 0.0;
  if (sim.environment) sim.environment_normal = normal.normalized();
  sim.environment_offset_m = config::ReadNumber(map, k::kSimEnvOffset);
  sim.environment_stiffness_N_per_m = config::ReadNumber(map, k::kSimEnvStiffness);
  sim.environment_damping_Ns_per_m = config::ReadNumber(map, k::kSimEnvDamping);
}

MitJointConfig ReadMitJoint(const Field& f, const std::map<std::string, fieldbus::MitMotorModel>& models,
                            const std::string& models_file) {
  const Map map(
      f, {"model", "esc_id", "master_id", "sign", "offset_rad", "gear_ratio", "kp_Nm_per_rad", "kd_Nms_per_rad"});
  MitJointConfig j;
  const Field model = map.Required("model");
  j.model = model.AsString();
  try {
    j.motor = fieldbus::FindMitMotorModel(models, j.model, models_file);
  } catch (const Error& e) {
    model.Fail(e.what());
  }
  j.esc_id = static_cast<std::uint32_t>(config::IntInRange(map.Required("esc_id"), 1, 0x7FE));
  j.master_id = static_cast<std::uint32_t>(config::IntInRange(map.Required("master_id"), 1, 0x7FE));
  if (auto v = map.Optional("sign")) {
    j.sign = config::Finite(*v);
    if (j.sign != 1.0 && j.sign != -1.0) v->Fail("must be 1 or -1");
  }
  if (auto v = map.Optional("offset_rad")) j.offset_rad = config::Finite(*v);
  if (auto v = map.Optional("gear_ratio")) j.gear_ratio = config::Positive(*v, "");
  if (auto v = map.Optional("kp_Nm_per_rad")) j.kp_Nm_per_rad = config::NonNegative(*v, "N·m/rad");
  if (auto v = map.Optional("kd_Nms_per_rad")) j.kd_Nms_per_rad = config::NonNegative(*v, "N·m·s/rad");
  return j;
}

void ReadMit(const Field& f, MitJointBusConfig& mit) {
  namespace k = arm_keys;
  std::vector<std::string> names = config::KeysUnder(k::All(), "mit.");
  names.insert(names.end(), {"can", "joints"});  // the bus section and the joints list: read below
  const Map map(f, names);
  mit.simulated = config::ReadChoice(map, k::kMitBus) == 0;
  if (!mit.simulated) fieldbus::ReadCanPortSection(map.Required("can"), mit.can);
  if (auto v = map.Optional("can"); v && mit.simulated) v->Fail("a bus section, but bus is simulated; remove it");
  mit.fd = config::ReadBool(map, k::kMitFd);
  mit.nominal_bitrate_bit_per_s = config::ReadNumber(map, k::kMitNominalBitrate);
  mit.data_bitrate_bit_per_s = config::ReadNumber(map, k::kMitDataBitrate);
  mit.max_bus_load = config::ReadNumber(map, k::kMitMaxBusLoad);
  mit.rate_hz = config::ReadNumber(map, k::kMitRate);
  mit.control = config::ReadChoiceAs<MitControl>(map, k::kMitControl);
  mit.missing_limit = config::ReadInteger(map, k::kMitMissingLimit);
  mit.answer_timeout_ms = config::ReadNumber(map, k::kMitAnswerTimeout);
  mit.motor_timeout_ms = config::ReadNumber(map, k::kMitMotorTimeout);
  mit.reply_wait_us = config::ReadNumber(map, k::kMitReplyWait);
  mit.temperature_warning_C = config::ReadNumber(map, k::kMitTemperatureWarning);
  mit.temperature_fault_C = config::ReadNumber(map, k::kMitTemperatureFault);
  const std::string models = config::ReadText(map, arm_keys::kMitModelsFile);
  const std::string models_file =
      models.empty() ? fieldbus::DefaultMitMotorModelsPath() : config::BesideConfigFile(f.file(), models);
  const auto table = fieldbus::ReadMitMotorModels(models_file);
  const Field joints = map.Required("joints");
  for (const Field& item : joints.AsList()) mit.joints.push_back(ReadMitJoint(item, table, models_file));
  if (mit.joints.empty()) joints.Fail("needs one motor per joint");
  try {
    CheckMitBusLoad(mit, "device.arm.mit");
  } catch (const Error& e) {
    joints.Fail(e.what());
  }
}

Cia402JointConfig ReadCia402Joint(const Field& f) {
  const Map map(f, {"bus", "node_id", "rated_torque_Nm", "max_torque_Nm", "position_rad_per_count",
                    "velocity_rad_per_s_per_unit", "sign", "offset_rad", "gear_ratio"});
  Cia402JointConfig j;
  if (auto v = map.Optional("bus")) j.bus = config::IntInRange(*v, 0, 15);
  j.node_id = static_cast<std::uint8_t>(config::IntInRange(map.Required("node_id"), 1, 127));
  j.rated_torque_Nm = config::Positive(map.Required("rated_torque_Nm"), "N·m");
  j.max_torque_Nm = config::Positive(map.Required("max_torque_Nm"), "N·m");
  if (auto v = map.Optional("position_rad_per_count")) j.position_rad_per_count = config::Positive(*v, "rad");
  if (auto v = map.Optional("velocity_rad_per_s_per_unit")) {
    j.velocity_rad_per_s_per_unit = config::Positive(*v, "rad/s");
  }
  if (auto v = map.Optional("sign")) {
    j.sign = config::Finite(*v);
    if (j.sign != 1.0 && j.sign != -1.0) v->Fail("must be 1 or -1");
  }
  if (auto v = map.Optional("offset_rad")) j.offset_rad = config::Finite(*v);
  if (auto v = map.Optional("gear_ratio")) j.gear_ratio = config::Positive(*v, "");
  return j;
}

void ReadCia402(const Field& f, Cia402JointBusConfig& c) {
  namespace k = arm_keys;
  std::vector<std::string> names = config::KeysUnder(k::All(), "cia402.");
  names.insert(names.end(), {"buses", "joints"});  // the bus sections and the joints: lists, read below
  const Map map(f, names);
  c.simulated = config::ReadChoice(map, k::kCia402Bus) == 0;
  if (!c.simulated) {
    for (const Field& item : map.Required("buses").AsList()) {
      c.buses.emplace_back();
      fieldbus::ReadCanPortSection(item, c.buses.back());
    }
  }
  if (auto v = map.Optional("buses"); v && c.simulated) v->Fail("bus sections, but bus is simulated; remove them");
  c.nominal_bitrate_bit_per_s = config::ReadNumber(map, k::kCia402NominalBitrate);
  c.max_bus_load = config::ReadNumber(map, k::kCia402MaxBusLoad);
  c.rate_hz = config::ReadNumber(map, k::kCia402Rate);
  c.stale_after_ms = config::ReadNumber(map, k::kCia402Stale);
  c.drive_heartbeat_period_ms = config::ReadNumber(map, k::kCia402HeartbeatPeriod);
  c.heartbeat_timeout_ms = config::ReadNumber(map, k::kCia402HeartbeatTimeout);
  c.host_node_id = static_cast<std::uint8_t>(config::ReadInteger(map, k::kCia402HostNodeId));
  c.host_heartbeat_period_ms = config::ReadNumber(map, k::kCia402HostHeartbeatPeriod);
  c.drive_consumer_timeout_ms = config::ReadNumber(map, k::kCia402DriveConsumerTimeout);
  if (c.drive_consumer_timeout_ms > 0.0 && !(c.drive_consumer_timeout_ms > c.host_heartbeat_period_ms)) {
    const std::optional<Field> at = map.Optional("drive_consumer_timeout_ms");
    (at ? *at : map.Required("host_heartbeat_period_ms"))
        .Fail(fmt::format("drive_consumer_timeout_ms ({:g} ms) must be 0 (off) or more than host_heartbeat_period_ms "
                          "({:g} ms)",
                          c.drive_consumer_timeout_ms, c.host_heartbeat_period_ms));
  }
  c.sdo_timeout_ms = config::ReadNumber(map, k::kCia402SdoTimeout);
  c.activate_timeout_ms = config::ReadNumber(map, k::kCia402ActivateTimeout);
  const Field joints = map.Required("joints");
  for (const Field& item : joints.AsList()) c.joints.push_back(ReadCia402Joint(item));
  if (c.joints.empty()) joints.Fail("needs one drive per joint");
  if (!c.simulated && c.bus_count() > static_cast<int>(c.buses.size())) {
    joints.Fail("the joints use " + std::to_string(c.bus_count()) + " buses, buses has " +
                std::to_string(c.buses.size()));
  }
  for (int b = 0; b < c.bus_count(); ++b) {
    bool used = false;
    for (const Cia402JointConfig& j : c.joints) used = used || j.bus == b;
    if (!used) joints.Fail("no joint on bus " + std::to_string(b) + " (bus indices run from 0 without gaps)");
  }
  for (std::size_t i = 0; i < c.joints.size(); ++i) {
    for (std::size_t k = 0; k < i; ++k) {
      if (c.joints[k].bus == c.joints[i].bus && c.joints[k].node_id == c.joints[i].node_id) {
        joints.Fail("joints " + std::to_string(k + 1) + " and " + std::to_string(i + 1) + " share node " +
                    std::to_string(c.joints[i].node_id) + " on bus " + std::to_string(c.joints[i].bus));
      }
    }
  }
  try {
    CheckCia402BusLoad(c, "device.arm.cia402");
  } catch (const Error& e) {
    joints.Fail(e.what());
  }
}

void ReadFixtureSweep(const Field& f, FixtureSweepConfig& sweep) {
  namespace k = arm_keys;
  const Map map(f, {"samples", "plane_distance_m", "seed", "bucket"});
  sweep.samples = config::ReadInteger(map, k::kSweepSamples);
  sweep.plane_distance_m = config::ReadNumber(map, k::kSweepDistance);
  sweep.seed = static_cast<std::uint64_t>(config::ReadInteger(map, k::kSweepSeed));
  sweep.bucket = config::ReadNumber(map, k::kSweepBucket);
}

void ReadRuntimeLimit(const Field& f, ConfigurationLimitOptions& o) {
  namespace k = arm_keys;
  const Map map(f, {"enabled", "rate_hz", "margin", "hysteresis", "max_force_rate_N_per_s", "max_penetration_m"});
  o.enabled = config::ReadBool(map, k::kRuntimeEnabled);
  o.rate_hz = config::ReadNumber(map, k::kRuntimeRate);
  o.margin = config::ReadNumber(map, k::kRuntimeMargin);
  o.hysteresis = config::ReadNumber(map, k::kRuntimeHysteresis);
  o.max_force_rate_N_per_s = config::ReadNumber(map, k::kRuntimeForceRate);
  o.max_penetration_m = config::ReadNumber(map, k::kRuntimePenetration);
}

ArmSection ReadArm(const Field& f, int dof) {
  namespace k = arm_keys;
  const Map map(f, {"urdf",
                    "base_link",
                    "tool_link",
                    "tool_offset_m",
                    "workspace_origin_m",
                    "gravity_m_per_s2",
                    "orientation",
                    "orientation_stiffness_Nm_per_rad",
                    "orientation_damping_Nms_per_rad",
                    "posture_stiffness_Nm_per_rad",
                    "posture_damping_Nms_per_rad",
                    "posture_q_rad",
                    "joint_limit_margin_rad",
                    "joint_limit_stiffness_Nm_per_rad",
                    "min_manipulability",
                    "coriolis_compensation",
                    "friction_viscous_Nms_per_rad",
                    "friction_coulomb_Nm",
                    "joint_limits",
                    "actuators",
                    "mit",
                    "cia402",
                    "simulation",
                    "fixture_sweep",
                    "runtime_limit"});
  if (dof != 3) {
    f.Fail("the arm backend is a task-space device of dof 3 (the tool point's x, y, z); the config's dof is " +
           std::to_string(dof));
  }
  ArmSection s;
  s.chain.urdf_file = config::BesideConfigFile(f.file(), config::ReadText(map, k::kUrdf));
  s.chain.base_link = config::ReadText(map, k::kBaseLink);
  s.chain.tool_link = config::ReadText(map, k::kToolLink);
  s.chain.p_LT = ToVector3(config::ReadDofValue(map, k::kToolOffset, 3));
  s.workspace_origin_m = ToVector3(config::ReadDofValue(map, k::kWorkspaceOrigin, 3));
  s.gravity_m_per_s2 = config::ReadNumber(map, k::kGravity);
  ArmTorqueConfig& t = s.device.torque;
  t.hold_orientation = config::ReadChoice(map, k::kOrientation) == 1;
  t.orientation_stiffness_Nm_per_rad = config::ReadNumber(map, k::kOrientationStiffness);
  t.orientation_damping_Nms_per_rad = config::ReadNumber(map, k::kOrientationDamping);
  t.posture_stiffness_Nm_per_rad = config::ReadNumber(map, k::kPostureStiffness);
  t.posture_damping_Nms_per_rad = config::ReadNumber(map, k::kPostureDamping);
  if (auto v = map.Optional("posture_q_rad")) s.posture_q_rad = ReadList(*v, "rad");
  t.limit_margin = config::ReadNumber(map, k::kLimitMargin);
  t.limit_stiffness_Nm_per_rad = config::ReadNumber(map, k::kLimitStiffness);
  s.device.min_manipulability = config::ReadNumber(map, k::kMinManipulability);
  t.coriolis_compensation = config::ReadBool(map, k::kCoriolis);
  t.friction_viscous_Nms_per_rad = config::ReadNumber(map, k::kFrictionViscous);
  t.friction_coulomb_Nm = config::ReadNumber(map, k::kFrictionCoulomb);
  if (auto v = map.Optional("joint_limits")) {
    for (const Field& item : v->AsList()) s.chain.limit_overrides.push_back(ReadLimit(item));
  }
  const int actuators = config::ReadChoice(map, k::kActuators);
  s.mit_actuators = actuators == 1;
  s.cia402_actuators = actuators == 2;
  if (auto v = map.Optional("simulation")) ReadSimulation(*v, s.simulation, s.initial_q_rad);
  if (s.mit_actuators) {
    ReadMit(map.Required("mit"), s.mit);
  } else if (auto v = map.Optional("mit")) {
    v->Fail("an MIT motors section, but actuators is not mit; remove it or set actuators: mit");
  }
  if (s.cia402_actuators) {
    ReadCia402(map.Required("cia402"), s.cia402);
  } else if (auto v = map.Optional("cia402")) {
    v->Fail("a CiA 402 drives section, but actuators is not cia402; remove it or set actuators: cia402");
  }
  if (auto v = map.Optional("fixture_sweep")) ReadFixtureSweep(*v, s.fixture_sweep);
  if (auto v = map.Optional("runtime_limit")) ReadRuntimeLimit(*v, s.runtime_limit);
  return s;
}

JointVector ToJoints(const std::vector<double>& values, int joints, const ArmSection& section, const char* key) {
  if (values.empty()) return JointVector{};
  if (static_cast<int>(values.size()) != joints) {
    throw Error("device.arm." + std::string(key) + " has " + std::to_string(values.size()) + " values; the chain '" +
                section.chain.base_link + "' to '" + section.chain.tool_link + "' in '" + section.chain.urdf_file +
                "' has " + std::to_string(joints) + " joints");
  }
  JointVector v(joints);
  for (int i = 0; i < joints; ++i) v[i] = values[static_cast<std::size_t>(i)];
  return v;
}

std::string List(const JointVector& q) {
  std::string text;
  for (int i = 0; i < q.size(); ++i) text += fmt::format("{}{:.3f}", i > 0 ? ", " : "", q[i]);
  return text;
}

/// The start-up check's sweep (docs/arms.md, "Stability"): the plane is in the reported frame (p_BT − origin).
AnalysisSweep SweepArm(const ArmSection& section, const DofVector& normal, double offset_m) {
  AnalysisSweep result;
  const FixtureSweepConfig& c = section.fixture_sweep;
  if (c.samples == 0 || normal.size() != 3) return result;
  ArmModel model(BuildArmChain(section.chain), section.gravity_B());
  const Eigen::Vector3d n = Eigen::Vector3d(normal[0], normal[1], normal[2]).normalized();
  const double offset_B =
      offset_m / Eigen::Vector3d(normal[0], normal[1], normal[2]).norm() + n.dot(section.workspace_origin_m);
  const FixtureSweep sweep =
      SweepNearPlane(model, c, section.simulation.viscous_Nms_per_rad, n, offset_B, section.device.min_manipulability);
  result.summary = fmt::format(
      "{} configurations drawn within the joint limits (seed {}), {} with the tool within {} m of the plane, {} of "
      "them singular or immobile along n; {} buckets of {} % in apparent mass and damping",
      sweep.sampled, c.seed, sweep.near_plane, c.plane_distance_m, sweep.skipped, sweep.buckets.size(),
      100.0 * c.bucket);
  for (const SweptConfiguration& s : sweep.buckets) {
    const Eigen::Vector3d p = s.p_BT - section.workspace_origin_m;
    result.configurations.push_back(
        {s.along_normal.mass_kg, s.along_normal.damping_Ns_per_m,
         fmt::format("q = ({}) rad, tool at ({:.4f}, {:.4f}, {:.4f}) m", List(s.q), p.x(), p.y(), p.z()),
         s.bucket_size});
  }
  return result;
}

}  // namespace

std::unique_ptr<SimulatedArm> MakeSimulatedArm(const ArmSection& section) {
  ArmChain chain = BuildArmChain(section.chain);
  SimulatedArmConfig sim = section.simulation;
  sim.initial_q = ToJoints(section.initial_q_rad, chain.joint_count(), section, "simulation.initial_q_rad");
  return std::make_unique<SimulatedArm>(std::move(chain), section.gravity_B(), sim);
}

std::unique_ptr<MitJointBus> MakeMitJointBus(const ArmSection& section) {
  const ArmChain chain = BuildArmChain(section.chain);
  if (static_cast<int>(section.mit.joints.size()) != chain.joint_count()) {
    throw Error("device.arm.mit.joints has " + std::to_string(section.mit.joints.size()) + " motors; the chain '" +
                section.chain.base_link + "' to '" + section.chain.tool_link + "' in '" + section.chain.urdf_file +
                "' has " + std::to_string(chain.joint_count()) + " joints");
  }
  std::vector<std::string> names;
  for (const JointSpec& j : chain.joints) names.push_back(j.name);
  if (section.mit.simulated) {
    ArmSection plant_section = section;
    plant_section.simulation.substeps = 1;  // the plant steps the arm once per its own substep
    auto plant =
        std::make_unique<SimulatedMitArm>(MakeSimulatedArm(plant_section), section.mit, section.simulation.substeps);
    auto port = plant->MakeHostPort();
    return std::make_unique<MitJointBus>(section.mit, std::move(plant), std::move(port), names);
  }
  auto port = fieldbus::OpenCanPort(section.mit.can, MitJointBus::ReceiveOptions(section.mit));
  return std::make_unique<MitJointBus>(section.mit, nullptr, std::move(port), names);
}

std::unique_ptr<Cia402JointBus> MakeCia402JointBus(const ArmSection& section) {
  const ArmChain chain = BuildArmChain(section.chain);
  if (static_cast<int>(section.cia402.joints.size()) != chain.joint_count()) {
    throw Error("device.arm.cia402.joints has " + std::to_string(section.cia402.joints.size()) +
                " drives; the chain '" + section.chain.base_link + "' to '" + section.chain.tool_link + "' in '" +
                section.chain.urdf_file + "' has " + std::to_string(chain.joint_count()) + " joints");
  }
  std::vector<std::string> names;
  for (const JointSpec& j : chain.joints) names.push_back(j.name);
  std::unique_ptr<Cia402Plant> plant;
  if (section.cia402.simulated) {
    ArmSection plant_section = section;
    plant_section.simulation.substeps = 1;  // the plant steps the arm once per its own substep
    plant = std::make_unique<SimulatedCia402Arm>(MakeSimulatedArm(plant_section), section.cia402,
                                                 section.simulation.substeps);
  }
  return std::make_unique<Cia402JointBus>(section.cia402, std::move(plant), names);
}

std::unique_ptr<ArmDevice> MakeArmDevice(const ArmSection& section) {
  auto model = std::make_unique<ArmModel>(BuildArmChain(section.chain), section.gravity_B());
  ArmDeviceConfig device = section.device;
  device.workspace_origin_m = section.workspace_origin_m;
  device.torque.posture_q = ToJoints(section.posture_q_rad, model->joint_count(), section, "posture_q_rad");
  std::unique_ptr<JointBus> bus;
  if (section.mit_actuators) {
    bus = MakeMitJointBus(section);
  } else if (section.cia402_actuators) {
    bus = MakeCia402JointBus(section);
  } else {
    bus = MakeSimulatedArm(section);
  }
  return std::make_unique<ArmDevice>(std::move(model), std::move(bus), device);
}

DeviceBackend ArmBackend() {
  DeviceBackend b;
  b.name = "arm";
  b.description = "a URDF arm (KDL): joint actuators behind a seam, tool point as a 3-DOF task-space device";
  b.nominal.dof = 3;
  b.nominal.rendering = Rendering::kActiveForce;
  b.nominal.measures_velocity = true;
  b.nominal.measures_force = false;
  b.keys = {
      {"posture_q_rad", "the null-space posture, one angle per joint (rad); default the middle of each range"},
      {"joint_limits", "list of overrides of the URDF's joint limits"},
      {"joint_limits[].joint", "the URDF joint's name"},
      {"joint_limits[].lower_rad", "lower position limit (rad)"},
      {"joint_limits[].upper_rad", "upper position limit (rad)"},
      {"joint_limits[].max_velocity_rad_per_s", "velocity limit (rad/s), > 0"},
      {"joint_limits[].max_effort_Nm", "torque limit (N·m), > 0: every torque is clamped to it"},
      {"simulation", "the simulated arm (actuators: simulated)"},
      {"simulation.initial_q_rad", "start configuration, one angle per joint (rad); default the middle of each range"},
      {"mit.can", "the bus: medium (socketcan | emulated), interface, bus, connect_timeout_ms (docs/can.md)"},
      {"mit.joints", "one motor per joint in the chain's order"},
      {"mit.joints[].model", "the models table's name (DM-J4310, DM-J4340, DM-J8009, ...)"},
      {"mit.joints[].esc_id", "the motor's CAN id (1..0x7FE)"},
      {"mit.joints[].master_id", "the id it answers on (1..0x7FE, unique on the bus)"},
      {"mit.joints[].sign", "1 or -1: the motor turns with or against the URDF joint's axis (default 1)"},
      {"mit.joints[].offset_rad", "the joint's position when the motor reads 0 (rad, default 0)"},
      {"mit.joints[].gear_ratio", "motor turns per joint turn, > 0 (default 1)"},
      {"mit.joints[].kp_Nm_per_rad", "control: pd, joint side (N·m/rad)"},
      {"mit.joints[].kd_Nms_per_rad", "control: pd, joint side (N·m·s/rad)"},
      {"cia402.buses", "one CAN section per bus index: medium, interface, bus, connect_timeout_ms (docs/can.md)"},
      {"cia402.joints", "one drive per joint in the chain's order"},
      {"cia402.joints[].bus", "the joint's bus: an index into cia402.buses from 0 (default 0)"},
      {"cia402.joints[].node_id", "the drive's node ID (1..127, unique on its bus)"},
      {"cia402.joints[].rated_torque_Nm", "0x6076, drive side (N·m): 0x6071 is in per mille of it"},
      {"cia402.joints[].max_torque_Nm", "0x6072, drive side (N·m): every target is clamped to it"},
      {"cia402.joints[].position_rad_per_count", "0x6064's unit, drive side (default 1/4096)"},
      {"cia402.joints[].velocity_rad_per_s_per_unit", "0x606C's unit, drive side (default 1/4096)"},
      {"cia402.joints[].sign", "1 or -1: the drive turns with or against the URDF joint's axis (default 1)"},
      {"cia402.joints[].offset_rad", "the joint's position when the drive reads 0 (rad, default 0)"},
      {"cia402.joints[].gear_ratio", "drive turns per joint turn, > 0 (default 1)"},
  };
  AdoptKeyTable(b, arm_keys::All());
  b.section_required = true;
  b.read = [](const Field* section, const SectionContext& context) -> std::any {
    return ReadArm(*section, context.dof);
  };
  b.make = [](const DeviceConfig& config) -> std::unique_ptr<Device> {
    return MakeArmDevice(config.Section<ArmSection>());
  };
  b.model = [](const DeviceConfig& config) {
    // The apparent mass along x, y and z at the start configuration, and the simulated joints' viscous friction
    // seen at the tool likewise (docs/arms.md, "Stability"): the per-axis model of the start-up check.
    const ArmSection& section = config.Section<ArmSection>();
    ArmModel model(BuildArmChain(section.chain), section.gravity_B());
    JointVector q = ToJoints(section.initial_q_rad, model.joint_count(), section, "simulation.initial_q_rad");
    if (q.size() == 0) {
      q = JointVector(model.joint_count());
      for (int i = 0; i < model.joint_count(); ++i) {
        const JointSpec& j = model.arm().joints[static_cast<std::size_t>(i)];
        q[i] = j.bounded ? 0.5 * (j.lower + j.upper) : 0.0;
      }
    }
    if (!model.Update(q, JointVector(model.joint_count()))) {
      return AnalysisModel::NotApplicable("the arm's model cannot be evaluated at its start configuration");
    }
    AnalysisModel m;
    m.mass_kg = DofVector(3);
    m.damping_Ns_per_m = DofVector(3);
    for (int axis = 0; axis < 3; ++axis) {
      const NormalModel along = ModelAlong(model, Eigen::Vector3d::Unit(axis), section.simulation.viscous_Nms_per_rad);
      m.mass_kg[axis] = along.mass_kg;
      m.damping_Ns_per_m[axis] = along.damping_Ns_per_m;
    }
    if (!m.mass_kg.allFinite()) {
      return AnalysisModel::NotApplicable("the arm is singular at its start configuration");
    }
    return m;
  };
  b.sweep = [](const DeviceConfig& config, const DofVector& normal, double offset_m) {
    return SweepArm(config.Section<ArmSection>(), normal, offset_m);
  };
  b.configuration_model = [](const DeviceConfig& config) -> ConfigurationModel {
    // One model per process, evaluated by the run-time limit's thread alone (docs/arms.md, "Stability").
    const ArmSection& section = config.Section<ArmSection>();
    auto model = std::make_shared<ArmModel>(BuildArmChain(section.chain), section.gravity_B());
    const double damping = section.simulation.viscous_Nms_per_rad;
    return [model, damping](const DeviceConfiguration& c, const DofVector& normal) {
      const int n = model->joint_count();
      if (c.count != n || normal.size() != 3) {
        throw Error("arm: a configuration of " + std::to_string(c.count) + " values and a direction of " +
                    std::to_string(normal.size()) + " for a chain of " + std::to_string(n) + " joints in 3 D");
      }
      JointVector q(n);
      for (int i = 0; i < n; ++i) q[i] = c.values[static_cast<std::size_t>(i)];
      if (!model->Update(q, JointVector(n))) throw Error("arm: the model cannot be evaluated at q = (" + List(q) + ")");
      const Eigen::Vector3d n_B = Eigen::Vector3d(normal[0], normal[1], normal[2]).normalized();
      const NormalModel along = ModelAlong(*model, n_B, damping);
      const Eigen::Vector3d& p = model->p_BT();
      return AnalysisConfiguration{along.mass_kg, along.damping_Ns_per_m,
                                   fmt::format("q = ({}) rad, tool at ({:.4f}, {:.4f}, {:.4f}) m in the base frame",
                                               List(q), p.x(), p.y(), p.z()),
                                   1};
    };
  };
  b.configuration_limit = [](const DeviceConfig& config) { return config.Section<ArmSection>().runtime_limit; };
  return b;
}

}  // namespace teleop::device::arm

TELEOP_REGISTER_DEVICE(arm, teleop::device::arm::ArmBackend())
