// `device.hybrid.fieldbus`: the real rig from YAML (docs/configuration.md).
#include "device/hybrid/hybrid_fieldbus_section.hpp"

#include <cmath>
#include <string>

#include "teleop/error.hpp"
#include "teleop/fieldbus/can_port_yaml.hpp"
#include "teleop/fieldbus/modbus_yaml.hpp"

namespace teleop::device::hybrid {
namespace {

using config::Field;
using config::Finite;
using config::Map;
using config::Positive;

double AtLeast(const Field& f, double low, const char* unit) {
  const double v = Finite(f);
  if (v < low) f.Fail("must be >= " + config::Num(low) + " " + unit + ", got " + config::Num(v));
  return v;
}

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
  const Map probe(f, {"bus", "cob_id", "encoding", "scale_N_per_count", "offset_N", "stale_after_ms"});
  const Field bus = probe.Required("bus");
  const std::string kind = bus.AsString();
  if (kind == "modbus") {
    const Map m(f, {"bus"});
    c.force_sensor = ForceSensorBus::kModbus;
    return;
  }
  if (kind != "can") bus.Fail("must be can or modbus; got '" + kind + "'");
  c.force_sensor = ForceSensorBus::kCan;
  fieldbus::CanForceSensorConfig& s = c.can_force_sensor;
  s.axes = 2;
  s.cob_id = static_cast<std::uint32_t>(config::IntInRange(probe.Required("cob_id"), 1, 0x7FF));
  if (s.cob_id == fieldbus::canopen::cob::kSync) probe.Required("cob_id").Fail("0x080 is the SYNC");
  if (auto v = probe.Optional("encoding")) {
    const std::string e = v->AsString();
    if (e == "int16") {
      s.encoding = fieldbus::ForceSensorEncoding::kInt16;
    } else if (e == "int32") {
      s.encoding = fieldbus::ForceSensorEncoding::kInt32;
    } else {
      v->Fail("must be int16 or int32; got '" + e + "'");
    }
  }
  const Field scale = probe.Required("scale_N_per_count");
  s.scale_N_per_count = Finite(scale);
  if (s.scale_N_per_count == 0.0) scale.Fail("must not be 0 (N per raw count)");
  if (auto v = probe.Optional("offset_N")) {
    const DofVector o = config::ReadDofVector(*v, 2, Finite);
    s.offset_N[0] = o(0);
    s.offset_N[1] = o(1);
  }
  if (auto v = probe.Optional("stale_after_ms")) s.stale_after_ms = Positive(*v, "ms");
}

}  // namespace

void ReadHybridFieldbusSection(const Field& section, HybridFieldbusRigConfig& out) {
  const Map m(section,
              {"can", "cycle_period_ms", "sync_cob_id", "drives", "modbus", "force_sensor", "activate_timeout_ms"});
  HybridFieldbusConfig& c = out.device;
  fieldbus::ReadCanPortSection(m.Required("can"), out.can, fieldbus::CanMediumKey::kRequired);
  double cycle_period_s = 1e-3;
  if (auto v = m.Optional("cycle_period_ms")) cycle_period_s = config::InRange(*v, 0.1, 100.0, "ms") * 1e-3;
  if (auto v = m.Optional("sync_cob_id")) {
    c.sync_cob_id = static_cast<std::uint32_t>(config::IntInRange(*v, 1, 0x7FF));
  }
  const Field drives = m.Required("drives");
  if (!drives.IsSequence()) drives.Fail("must be a list of the two drives (joint 1, joint 2)");
  const std::vector<Field> list = drives.AsList();
  if (list.size() != 2)
    drives.Fail("must list exactly two drives (joint 1, joint 2), got " + std::to_string(list.size()));
  for (std::size_t i = 0; i < 2; ++i) ReadDrive(list[i], c.drives[i], c.joint_offset_rad[i], cycle_period_s);
  if (c.drives[0].node_id == c.drives[1].node_id) list[1].Fail("node_id must differ from the first drive's");
  const Field modbus = m.Required("modbus");
  c.amplifier = fieldbus::ReadModbusConfig(modbus.node(), modbus.path(), modbus.file());
  ReadForceSensor(m.Required("force_sensor"), c);
  if (auto v = m.Optional("activate_timeout_ms")) c.activate_timeout_ms = AtLeast(*v, 1.0, "ms");
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
      {"fieldbus.cycle_period_ms", "the drives' SYNC period written to 0x1006 (ms), 0.1..100; default 1 (1/rate_hz)"},
      {"fieldbus.sync_cob_id", "COB-ID of the one SYNC per cycle the device sends, 1..0x7FF; default 0x080"},
      {"fieldbus.drives",
       "two CiA 402 drives (joint 1, joint 2): node_id, max_torque_Nm (drive shaft), joint_offset_deg, "
       "rated_torque_Nm, position_rad_per_count, velocity_rad_per_s_per_unit, sign, heartbeat_period_ms, "
       "heartbeat_timeout_ms, boot_timeout_ms, state_timeout_ms, stale_after_ms, sdo_timeout_ms, "
       "drive_consumer_timeout_ms"},
      {"fieldbus.modbus",
       "the brake amplifier (a Modbus section, docs/modbus.md): outputs brake_1_Nm, brake_2_Nm (safe_value = "
       "brake.max_torque_Nm); inputs force_x_N, force_y_N when force_sensor.bus is modbus, and an optional "
       "input clutch (a pedal on a discrete input: pressed while non-zero)"},
      {"fieldbus.force_sensor",
       "handle force sensor: bus modbus | can (cob_id, encoding int16|int32, scale_N_per_count, offset_N, "
       "stale_after_ms)"},
      {"fieldbus.activate_timeout_ms",
       "Activate: wait for the amplifier and the first SYNC answers (ms); default 1000"},
  };
}

}  // namespace teleop::device::hybrid
