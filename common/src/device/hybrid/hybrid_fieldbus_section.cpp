// `device.hybrid.fieldbus`: the real rig from YAML (docs/configuration.md).
#include "device/hybrid/hybrid_fieldbus_section.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "device/hybrid/hybrid_keys.hpp"
#include "teleop/config/key_table.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/can_port_yaml.hpp"
#include "teleop/fieldbus/modbus_yaml.hpp"

namespace teleop::device::hybrid {
namespace {

using config::Field;
using config::Finite;
using config::Map;
using config::Positive;

void ReadDrive(const Field& f, fieldbus::Cia402DriveConfig& d, double& joint_offset_rad, double cycle_period_s) {
  const Map m(f,
              {"node_id", "joint_offset_deg", "rated_torque_Nm", "max_torque_Nm", "position_rad_per_count",
               "velocity_rad_per_s_per_unit", "sign", "heartbeat_period_ms", "heartbeat_timeout_ms", "boot_timeout_ms",
               "state_timeout_ms", "stale_after_ms", "sdo_timeout_ms", "drive_consumer_timeout_ms"});
  d.produce_sync = false;  // the device produces the bus's SYNC
  d.cycle_period_s = cycle_period_s;
  d.node_id = static_cast<std::uint8_t>(config::IntInRange(m.Required("node_id"), 1, 127));
  if (auto v = m.Optional("joint_offset_deg")) joint_offset_rad = Finite(*v) * config::kDeg;
  if (auto v = m.Optional("rated_torque_Nm")) d.scaling.rated_torque_Nm = Positive(*v, "N·m");
  d.max_torque_Nm = Positive(m.Required("max_torque_Nm"), "N·m");
  if (auto v = m.Optional("position_rad_per_count")) d.scaling.position_rad_per_count = Positive(*v, "rad/count");
  if (auto v = m.Optional("velocity_rad_per_s_per_unit")) {
    d.scaling.velocity_rad_per_s_per_unit = Positive(*v, "rad/s per unit");
  }
  if (auto v = m.Optional("sign")) {
    const double s = Finite(*v);
    if (s != 1.0 && s != -1.0) v->Fail("must be 1 or -1");
    d.scaling.sign = s;
  }
  if (auto v = m.Optional("heartbeat_period_ms")) d.drive_heartbeat_period_ms = config::InRange(*v, 1.0, 65535.0, "ms");
  if (auto v = m.Optional("heartbeat_timeout_ms")) d.heartbeat_timeout_ms = Positive(*v, "ms");
  if (d.heartbeat_timeout_ms <= d.drive_heartbeat_period_ms) {
    f.Fail("heartbeat_timeout_ms (" + config::Num(d.heartbeat_timeout_ms) + ") must exceed heartbeat_period_ms (" +
           config::Num(d.drive_heartbeat_period_ms) + ")");
  }
  if (auto v = m.Optional("boot_timeout_ms")) d.boot_timeout_ms = Positive(*v, "ms");
  if (auto v = m.Optional("state_timeout_ms")) d.state_timeout_ms = Positive(*v, "ms");
  if (auto v = m.Optional("stale_after_ms")) {
    d.stale_after_ms = Positive(*v, "ms");
    if (d.stale_after_ms < 2.0 * cycle_period_s * 1e3) {
      v->Fail("must be at least two cycles (" + config::Num(2.0 * cycle_period_s * 1e3) +
              " ms), or a drive answering on the next SYNC reads as stale");
    }
  }
  if (auto v = m.Optional("sdo_timeout_ms")) d.sdo.timeout_ms = Positive(*v, "ms");
  if (auto v = m.Optional("drive_consumer_timeout_ms")) {
    d.drive_consumer_timeout_ms = config::InRange(*v, 0.0, 65535.0, "ms (0 = off)");
  }
}

void ReadForceSensor(const Field& f, HybridFieldbusConfig& c) {
  // The bus first, among the keys of both; then the keys of that bus only (modbus: none but bus).
  c.force_sensor = config::ReadChoiceAs<ForceSensorBus>(
      Map(f, config::KeysUnder(keys::All(), "fieldbus.force_sensor.", "*")), keys::kForceSensorBus);
  const Map m(f, config::KeysUnder(keys::All(), "fieldbus.force_sensor.",
                                   keys::kForceSensorBus.choices[static_cast<std::size_t>(c.force_sensor)]));
  if (c.force_sensor != ForceSensorBus::kCan) return;
  fieldbus::CanForceSensorConfig& s = c.can_force_sensor;
  s.axes = 2;
  s.cob_id = static_cast<std::uint32_t>(config::ReadInteger(m, keys::kCanSensorCobId));
  if (s.cob_id == fieldbus::canopen::cob::kSync) m.Required("cob_id").Fail("0x080 is the SYNC");
  s.encoding = config::ReadChoiceAs<fieldbus::ForceSensorEncoding>(m, keys::kCanSensorEncoding);
  s.scale_N_per_count = config::ReadNumber(m, keys::kCanSensorScale);
  if (s.scale_N_per_count == 0.0) m.Required("scale_N_per_count").Fail("must not be 0 (N per raw count)");
  const Eigen::Vector2d offset = config::ReadPair(m, keys::kCanSensorOffset);
  s.offset_N[0] = offset.x();
  s.offset_N[1] = offset.y();
  s.stale_after_ms = config::ReadNumber(m, keys::kCanSensorStale);
}

}  // namespace

void ReadHybridFieldbusSection(const Field& section, HybridFieldbusRigConfig& out) {
  std::vector<std::string> names = config::KeysUnder(keys::All(), "fieldbus.");
  names.insert(names.end(), {"can", "drives", "modbus"});  // read below: the shared CAN and Modbus readers, a list
  const Map m(section, names);
  HybridFieldbusConfig& c = out.device;
  fieldbus::ReadCanPortSection(m.Required("can"), out.can, fieldbus::CanMediumKey::kRequired);
  const double cycle_period_s = config::ReadNumber(m, keys::kFieldbusCyclePeriod) * 1e-3;
  c.sync_cob_id = static_cast<std::uint32_t>(config::ReadInteger(m, keys::kFieldbusSyncCobId));
  const Field drives = m.Required("drives");
  if (!drives.IsSequence()) drives.Fail("must be a list of the two drives (joint 1, joint 2)");
  const std::vector<Field> list = drives.AsList();
  if (list.size() != 2)
    drives.Fail("must list exactly two drives (joint 1, joint 2), got " + std::to_string(list.size()));
  for (std::size_t i = 0; i < 2; ++i) ReadDrive(list[i], c.drives[i], c.joint_offset_rad[i], cycle_period_s);
  if (c.drives[0].node_id == c.drives[1].node_id) list[1].Fail("node_id must differ from the first drive's");
  const Field modbus = m.Required("modbus");
  c.amplifier = fieldbus::ReadModbusConfig(modbus.node(), modbus.path(), modbus.file());
  ReadForceSensor(m.Required(config::LeafOf(keys::kFieldbusForceSensorSection)), c);
  c.activate_timeout_ms = config::ReadNumber(m, keys::kFieldbusActivateTimeout);
  try {
    c.Validate();
  } catch (const Error& e) {
    section.Fail(e.what());
  }
}

std::vector<ConfigKey> HybridFieldbusKeys() {
  return {
      {"fieldbus.can",
       "the drives' CAN bus: medium socketcan (interface) | emulated (bus HOST:PORT of teleop-canbus), "
       "connect_timeout_ms"},
      {"fieldbus.drives",
       "two CiA 402 drives (joint 1, joint 2): node_id, max_torque_Nm (drive shaft), joint_offset_deg, "
       "rated_torque_Nm, position_rad_per_count, velocity_rad_per_s_per_unit, sign, heartbeat_period_ms, "
       "heartbeat_timeout_ms, boot_timeout_ms, state_timeout_ms, stale_after_ms, sdo_timeout_ms, "
       "drive_consumer_timeout_ms"},
      {"fieldbus.modbus",
       "the brake amplifier (a Modbus section, docs/modbus.md): outputs brake_1_Nm, brake_2_Nm (safe_value = "
       "brake.max_torque_Nm); inputs force_x_N, force_y_N when force_sensor.bus is modbus, and an optional "
       "input clutch (a pedal on a discrete input: pressed while non-zero)"},
  };
}

}  // namespace teleop::device::hybrid
