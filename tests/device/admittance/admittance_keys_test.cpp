// The admittance backend's key table (admittance_keys.hpp) against AdmittanceConfig: each optional key's default is
// the struct's, and a section with only the required keys reads as the struct's defaults.

#include "admittance_keys.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <any>
#include <string>

#include "admittance_device.hpp"
#include "teleop/config/yaml_reader.hpp"
#include "teleop/device/device_registry.hpp"
#include "teleop/error.hpp"

namespace teleop::device {
namespace {

AdmittanceConfig Read(const std::string& yaml, const std::string& file = "admittance.yaml") {
  const YAML::Node node = YAML::Load(yaml);
  const config::Field field(node, "device.admittance", &file);
  return std::any_cast<AdmittanceConfig>(FindDevice("admittance")->read(&field, SectionContext{Role::kSlave, 1}));
}

TEST(AdmittanceKeys, TheTablesDefaultsAreTheStructsAndTheReadersWhenAbsent) {
  namespace keys = admittance_keys;
  const AdmittanceConfig code{};  // a config built in code
  const AdmittanceConfig read =
      Read("{virtual_mass_kg: 2, virtual_damping_Ns_per_m: 8, can: {interface: can0}, drives: [{node_id: 3}]}");
  const auto same = [](double table, double in_code, double from_yaml, const char* key) {
    EXPECT_EQ(table, in_code) << key;
    EXPECT_EQ(from_yaml, in_code) << key;
  };
  same(keys::kMaxForce.default_value, code.max_force_N, read.max_force_N, "max_force_N");
  same(keys::kMaxVelocity.default_value, code.max_velocity_m_per_s, read.max_velocity_m_per_s, "max_velocity");
  same(keys::kPositionLoopBandwidth.default_value, code.position_loop_bandwidth_rad_per_s,
       read.position_loop_bandwidth_rad_per_s, "position_loop_bandwidth_rad_per_s");
  same(keys::kBandwidthRatio.default_value, code.bandwidth_ratio, read.bandwidth_ratio, "bandwidth_ratio");
  same(keys::kMaxStiffness.default_value, code.max_stiffness_N_per_m, read.max_stiffness_N_per_m, "max_stiffness");
  same(keys::kCyclePeriod.default_value * 1e-3, code.cycle_period_s, read.cycle_period_s, "cycle_period_ms");
  same(keys::kMaxTrackingError.default_value, code.max_tracking_error_m, read.max_tracking_error_m,
       "max_tracking_error_m");
  same(keys::kTrackingErrorCycles.default_value, code.tracking_error_cycles, read.tracking_error_cycles,
       "tracking_error_cycles");
  // The documented values (docs/configuration.md, rows generated from the table; config_docs_test).
  EXPECT_EQ(code.max_force_N, 50.0);
  EXPECT_EQ(code.bandwidth_ratio, 10.0);
  EXPECT_EQ(code.cycle_period_s, 0.001);
  EXPECT_EQ(code.tracking_error_cycles, 10);
  EXPECT_EQ(read.virtual_mass_kg[0], 2.0);
  EXPECT_EQ(read.virtual_damping_Ns_per_m[0], 8.0);
  // Each drive's keys: defaults from AdmittanceAxisConfig and its Cia402DriveConfig.
  const AdmittanceAxisConfig axis{};
  ASSERT_EQ(read.axes.size(), 1U);
  const AdmittanceAxisConfig& a = read.axes[0];
  EXPECT_EQ(a.drive.node_id, 3);
  same(keys::kDriveTransmission.default_value, axis.transmission_m_per_rad, a.transmission_m_per_rad, "transmission");
  same(keys::kDriveRatedTorque.default_value, axis.drive.scaling.rated_torque_Nm, a.drive.scaling.rated_torque_Nm,
       "rated_torque_Nm");
  same(keys::kDrivePositionUnit.default_value, axis.drive.scaling.position_rad_per_count,
       a.drive.scaling.position_rad_per_count, "position_rad_per_count");
  same(keys::kDriveVelocityUnit.default_value, axis.drive.scaling.velocity_rad_per_s_per_unit,
       a.drive.scaling.velocity_rad_per_s_per_unit, "velocity_rad_per_s_per_unit");
  same(keys::kDriveMaxTorque.default_value, axis.drive.max_torque_Nm, a.drive.max_torque_Nm, "max_torque_Nm");
  same(keys::kDriveHeartbeatPeriod.default_value, axis.drive.drive_heartbeat_period_ms,
       a.drive.drive_heartbeat_period_ms, "heartbeat_period_ms");
  same(keys::kDriveHeartbeatTimeout.default_value, axis.drive.heartbeat_timeout_ms, a.drive.heartbeat_timeout_ms,
       "heartbeat_timeout_ms");
  same(keys::kDriveStaleAfter.default_value, axis.drive.stale_after_ms, a.drive.stale_after_ms, "stale_after_ms");
  EXPECT_EQ(axis.drive.scaling.position_rad_per_count, 1.0 / 4096.0);
  // A value given is read in the key's unit.
  const AdmittanceConfig given = Read(
      "{virtual_mass_kg: 2, virtual_damping_Ns_per_m: 8, cycle_period_ms: 2, tracking_error_cycles: 4, "
      "can: {interface: can0}, drives: [{node_id: 3}]}");
  EXPECT_EQ(given.cycle_period_s, 0.002);
  EXPECT_EQ(given.tracking_error_cycles, 4);
}

// drives[].eds: a text key; its default is the default-constructed drive config's (no file), and a given path is read.
TEST(AdmittanceKeys, TheEdsKeysDefaultIsTheStructsAndAPathIsRead) {
  namespace keys = admittance_keys;
  const AdmittanceAxisConfig code{};
  EXPECT_EQ(std::string(keys::kDriveEds.default_text), code.drive.eds_file);
  int listed = 0;  // the backend lists the moved keys from its table (--list-devices, the docs rows)
  for (const config::KeySpec& spec : FindDevice("admittance")->key_table) {
    const std::string key = spec.key;
    listed += key == "drives[].eds" || key == "mode" ? 1 : 0;
  }
  EXPECT_EQ(listed, 2);
  const std::string head =
      "{virtual_mass_kg: 2, virtual_damping_Ns_per_m: 8, can: {interface: can0}, drives: [{node_id: 3";
  EXPECT_EQ(Read(head + "}]}").axes.at(0).drive.eds_file, code.drive.eds_file);
  EXPECT_EQ(Read(head + ", eds: drive.eds}]}").axes.at(0).drive.eds_file, "drive.eds");
  // A relative path is beside the config file (as link.security.key_file), an absolute one is kept.
  EXPECT_EQ(Read(head + ", eds: drive.eds}]}", "/rigs/lab/slave.yaml").axes.at(0).drive.eds_file,
            "/rigs/lab/drive.eds");
  EXPECT_EQ(Read(head + ", eds: eds/x.dcf}]}", "/rigs/lab/slave.yaml").axes.at(0).drive.eds_file,
            "/rigs/lab/eds/x.dcf");
  EXPECT_EQ(Read(head + ", eds: /opt/drives/a.eds}]}", "/rigs/lab/slave.yaml").axes.at(0).drive.eds_file,
            "/opt/drives/a.eds");
}

// mode: the table's default word is the default-constructed config's mode, absent reads as it, velocity and torque
// are read, and a wrong word is refused naming the key and the three words.
TEST(AdmittanceKeys, TheModeKeysDefaultIsTheStructsAndAWrongWordIsRefused) {
  namespace keys = admittance_keys;
  const AdmittanceConfig code{};
  EXPECT_EQ(keys::kModes.at(static_cast<std::size_t>(keys::kMode.default_choice)), code.mode);
  EXPECT_STREQ(keys::kMode.choices[keys::kMode.default_choice], "position");
  const std::string base =
      "virtual_mass_kg: 2, virtual_damping_Ns_per_m: 8, can: {interface: can0}, drives: [{node_id: 3}]";
  EXPECT_EQ(Read("{" + base + "}").mode, code.mode);
  EXPECT_EQ(Read("{mode: velocity, " + base + "}").mode, fieldbus::Cia402Mode::kCyclicSynchronousVelocity);
  EXPECT_EQ(Read("{mode: torque, " + base + "}").mode, fieldbus::Cia402Mode::kCyclicSynchronousTorque);
  for (const char* word : {"current", "csp"}) {
    try {
      (void)Read("{mode: " + std::string(word) + ", " + base + "}");
      ADD_FAILURE() << "accepted mode: " << word;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("'device.admittance.mode': must be position, velocity or torque, got '" +
                                           std::string(word) + "'"),
                std::string::npos)
          << e.what();
    }
  }
}

TEST(AdmittanceKeys, TheDirectionIsATableKeyAndZeroIsRefused) {
  const std::string base = "{virtual_mass_kg: 2, virtual_damping_Ns_per_m: 8, can: {interface: can0}, drives: [";
  EXPECT_EQ(admittance_keys::kDriveDirection.default_value, AdmittanceAxisConfig{}.drive.scaling.sign);
  EXPECT_EQ(Read(base + "{node_id: 3}]}").axes.at(0).drive.scaling.sign, 1.0);
  EXPECT_EQ(Read(base + "{node_id: 3, direction: -1}]}").axes.at(0).drive.scaling.sign, -1.0);
  for (const char* bad : {"0", "2"}) {
    try {
      (void)Read(base + "{node_id: 3, direction: " + bad + "}]}");
      ADD_FAILURE() << "direction " << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("drives[0].direction"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace teleop::device
