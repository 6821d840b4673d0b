// The `admittance` backend (docs/configuration.md, `device.admittance`; docs/cia402.md, "Admittance backend"): the
// config reader, the stability model (the virtual mass-damper, under the stated assumption) and the registration.

#include <fmt/format.h>

#include <cmath>
#include <memory>

#include "admittance_device.hpp"
#include "admittance_keys.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/backend_key_table.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/fieldbus/can_port_yaml.hpp"

namespace teleop::device {
namespace {

using config::Field;
using config::Map;

AdmittanceAxisConfig ReadDrive(const Field& f) {
  const Map map(f, config::KeysUnder(admittance_keys::All(), "drives[]."));
  AdmittanceAxisConfig a;
  fieldbus::Cia402DriveConfig& d = a.drive;
  namespace keys = admittance_keys;
  d.node_id = static_cast<std::uint8_t>(config::ReadInteger(map, keys::kDriveNodeId));
  a.transmission_m_per_rad = config::ReadNumber(map, keys::kDriveTransmission);
  d.scaling.rated_torque_Nm = config::ReadNumber(map, keys::kDriveRatedTorque);
  d.scaling.position_rad_per_count = config::ReadNumber(map, keys::kDrivePositionUnit);
  d.scaling.velocity_rad_per_s_per_unit = config::ReadNumber(map, keys::kDriveVelocityUnit);
  const int direction = config::ReadInteger(map, keys::kDriveDirection);
  if (direction == 0) map.Required(config::LeafOf(keys::kDriveDirection)).Fail("must be 1 or -1");
  d.scaling.sign = static_cast<double>(direction);
  d.max_torque_Nm = config::ReadNumber(map, keys::kDriveMaxTorque);
  d.drive_heartbeat_period_ms = config::ReadNumber(map, keys::kDriveHeartbeatPeriod);
  d.heartbeat_timeout_ms = config::ReadNumber(map, keys::kDriveHeartbeatTimeout);
  d.stale_after_ms = config::ReadNumber(map, keys::kDriveStaleAfter);
  // Beside the config file, as link.security.key_file: a rig's configs and its drives' EDS files move together.
  d.eds_file = config::BesideConfigFile(map.self().file(), config::ReadText(map, keys::kDriveEds));
  return a;
}

AdmittanceConfig ReadAdmittance(const Field& f, int dof) {
  const Map map(f, {"virtual_mass_kg", "virtual_damping_Ns_per_m", "mode", "max_force_N", "max_velocity_m_per_s",
                    "position_loop_bandwidth_rad_per_s", "bandwidth_ratio", "max_stiffness_N_per_m", "cycle_period_ms",
                    "max_tracking_error_m", "tracking_error_cycles", "can", "drives"});
  AdmittanceConfig c;
  c.dof = dof;
  namespace keys = admittance_keys;
  c.virtual_mass_kg = config::ReadDofValue(map, keys::kVirtualMass, dof);
  c.virtual_damping_Ns_per_m = config::ReadDofValue(map, keys::kVirtualDamping, dof);
  c.mode = keys::kModes.at(static_cast<std::size_t>(config::ReadChoice(map, keys::kMode)));
  c.max_force_N = config::ReadNumber(map, keys::kMaxForce);
  c.max_velocity_m_per_s = config::ReadNumber(map, keys::kMaxVelocity);
  c.position_loop_bandwidth_rad_per_s = config::ReadNumber(map, keys::kPositionLoopBandwidth);
  c.bandwidth_ratio = config::ReadNumber(map, keys::kBandwidthRatio);
  c.max_stiffness_N_per_m = config::ReadNumber(map, keys::kMaxStiffness);
  c.cycle_period_s = config::ReadNumber(map, keys::kCyclePeriod) * 1e-3;
  c.max_tracking_error_m = config::ReadNumber(map, keys::kMaxTrackingError);
  c.tracking_error_cycles = config::ReadInteger(map, keys::kTrackingErrorCycles);
  fieldbus::ReadCanPortSection(map.Required("can"), c.can);
  const Field drives = map.Required("drives");
  const std::vector<Field> items = drives.AsList();
  if (static_cast<int>(items.size()) != dof) {
    drives.Fail(fmt::format("needs {} entries (one drive per DOF), got {}", dof, items.size()));
  }
  for (const Field& item : items) c.axes.push_back(ReadDrive(item));
  for (std::size_t i = 0; i < c.axes.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (c.axes[i].drive.node_id == c.axes[j].drive.node_id) {
        items[i].Fail(fmt::format("node_id {} is used by drives[{}] too", c.axes[i].drive.node_id, j));
      }
    }
  }
  return c;
}

}  // namespace

/// The slave's model for the start-up check: the virtual mass-damper (m_v, b_v) — valid only while the drives'
/// position loop is much faster than the virtual dynamics (position_loop_bandwidth_rad_per_s ≥ bandwidth_ratio ·
/// b_v/m_v); otherwise, or when the bandwidth is not given, "not applicable" with the reason.
AnalysisModel AdmittanceModel(const AdmittanceConfig& a) {
  if (a.mode == fieldbus::Cia402Mode::kCyclicSynchronousTorque) {  // the axis itself: no loop to be faster than
    AnalysisModel m;
    m.mass_kg = a.virtual_mass_kg;
    m.damping_Ns_per_m = a.virtual_damping_Ns_per_m;
    return m;
  }
  if (!(a.position_loop_bandwidth_rad_per_s > 0.0)) {
    return AnalysisModel::NotApplicable(
        "device.admittance.position_loop_bandwidth_rad_per_s is not set: the virtual mass-damper models the slave only "
        "while the drives' position loop is much faster than it");
  }
  for (int i = 0; i < a.dof; ++i) {
    const double rate = a.virtual_damping_Ns_per_m[i] / a.virtual_mass_kg[i];
    if (a.position_loop_bandwidth_rad_per_s < a.bandwidth_ratio * rate) {
      return AnalysisModel::NotApplicable(fmt::format(
          "axis {}: the drives' position loop ({:g} rad/s) is not {:g} times faster than the virtual dynamics "
          "b_v/m_v = {:g} rad/s, so (m_v, b_v) does not describe the slave; raise the loop bandwidth or m_v",
          i, a.position_loop_bandwidth_rad_per_s, a.bandwidth_ratio, rate));
    }
    const double natural = std::sqrt(a.max_stiffness_N_per_m / a.virtual_mass_kg[i]);
    if (a.position_loop_bandwidth_rad_per_s < a.bandwidth_ratio * natural) {
      return AnalysisModel::NotApplicable(fmt::format(
          "axis {}: the drives' position loop ({:g} rad/s) is not {:g} times faster than the virtual mass on the "
          "stiffest spring, sqrt(K/m_v) = {:.3g} rad/s (max_stiffness_N_per_m {:g}), so (m_v, b_v) does not describe "
          "the slave in contact; raise the loop bandwidth or m_v",
          i, a.position_loop_bandwidth_rad_per_s, a.bandwidth_ratio, natural, a.max_stiffness_N_per_m));
    }
  }
  AnalysisModel m;
  m.mass_kg = a.virtual_mass_kg;
  m.damping_Ns_per_m = a.virtual_damping_Ns_per_m;
  return m;
}

DeviceBackend AdmittanceBackend() {
  DeviceBackend b;
  b.name = "admittance";
  b.description =
      "position- or velocity-controlled CiA 402 drives behind a virtual mass-damper (m_v, b_v) driven by the law's "
      "force, or torque-controlled ones driven by it directly";
  b.nominal.dof = 1;
  b.nominal.rendering = Rendering::kActiveForce;
  b.nominal.measures_velocity = true;
  b.nominal.measures_force = false;
  b.keys = {
      {"can", "the drives' bus"},
  };
  for (const fieldbus::CanPortKey& key : fieldbus::kCanPortKeys) {
    b.keys.push_back({std::string("can.") + key.key, key.description});
  }
  b.keys.push_back({"drives", "one drive per DOF, in axis order; their keys: drives[].*"});

  AdoptKeyTable(b, admittance_keys::All());  // the keys with a number or a word, written once (admittance_keys.hpp)
  b.section_required = true;
  b.read = [](const Field* section, const SectionContext& context) -> std::any {
    return ReadAdmittance(*section, context.dof);
  };
  b.make = [](const DeviceConfig& config) -> std::unique_ptr<Device> {
    AdmittanceConfig a = config.Section<AdmittanceConfig>();
    a.dof = config.dof;
    return std::make_unique<AdmittanceDevice>(a);
  };
  b.model = [](const DeviceConfig& config) { return AdmittanceModel(config.Section<AdmittanceConfig>()); };
  return b;
}

}  // namespace teleop::device

TELEOP_REGISTER_DEVICE(admittance, teleop::device::AdmittanceBackend())
