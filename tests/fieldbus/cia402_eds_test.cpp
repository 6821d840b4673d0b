// EDS (CiA 306) reading and the configuration check: the shipped EDS of the simulated drive
// (deploy/configs/admittance/simulated-cia402-drive.eds) read and checked against the drive itself over SDO, default
// COB-IDs taken from it, and bad input — a missing object, a wrong type, a wrong access, a mode the drive lacks, too
// few PDOs, a malformed file, a node that answers only some SDOs: each a clear error naming the file, the section and
// the key (or the object), and nothing enabled.
#include "teleop/fieldbus/cia402_eds.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "cia402_test_rig.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/canopen_eds.hpp"

namespace teleop::fieldbus {
namespace {

using canopen::Eds;

const std::string kEdsPath = std::string(TELEOP_SOURCE_DIR) + "/deploy/configs/admittance/simulated-cia402-drive.eds";

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The sample with `key` of `[section]` set to `value`.
std::string WithKey(std::string text, const std::string& section, const std::string& key, const std::string& value) {
  const std::size_t at = text.find("[" + section + "]\n");
  EXPECT_NE(at, std::string::npos) << section;
  const std::size_t k = text.find("\n" + key + "=", at);
  const std::size_t end = text.find('\n', k + 1);
  return text.substr(0, k + 1) + key + "=" + value + text.substr(end);
}

/// The sample without `[section]` (and its line in the object lists).
std::string Without(std::string text, const std::string& section) {
  const std::size_t at = text.find("[" + section + "]\n");
  const std::size_t end = text.find("\n\n", at);
  text.erase(at, end + 2 - at);
  return std::regex_replace(text, std::regex("\n[0-9]+=0x" + section), "");
}

std::string Joined(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += x + "\n";
  return s;
}

TEST(CanopenEds, ParsesValuesAsCia306WritesThem) {
  std::uint32_t v = 0;
  ASSERT_TRUE(canopen::ParseEdsValue("$NODEID+0x180", 5, v));
  EXPECT_EQ(v, 0x185u);
  ASSERT_TRUE(canopen::ParseEdsValue("0x200 + $NODEID", 1, v));
  EXPECT_EQ(v, 0x201u);
  ASSERT_TRUE(canopen::ParseEdsValue("1000", 0, v));
  EXPECT_EQ(v, 1000u);
  ASSERT_TRUE(canopen::ParseEdsValue("010", 0, v));  // octal
  EXPECT_EQ(v, 8u);
  ASSERT_TRUE(canopen::ParseEdsValue("-2", 0, v));
  EXPECT_EQ(v, 0xFFFF'FFFEu);
  EXPECT_FALSE(canopen::ParseEdsValue("0x", 0, v));
  EXPECT_FALSE(canopen::ParseEdsValue("12a", 0, v));
  EXPECT_FALSE(canopen::ParseEdsValue("", 0, v));
  EXPECT_FALSE(canopen::ParseEdsValue("09", 0, v));
}

TEST(CanopenEds, TheSampleEdsFitsEveryModeAndGivesTheDefaults) {
  const Eds eds = Eds::Load(kEdsPath);
  EXPECT_EQ(eds.rx_pdo_count(), 4);
  EXPECT_EQ(eds.tx_pdo_count(), 4);
  EXPECT_EQ(eds.MappingCapacity(0x1600), 8);
  ASSERT_NE(eds.Find(0x1018, 1), nullptr);
  EXPECT_EQ(eds.Find(0x1018, 1)->section, "1018sub1");
  EXPECT_EQ(*eds.Find(0x6060, 0)->data_type, canopen::datatype::kInteger8);
  for (const Cia402Mode mode : {Cia402Mode::kCyclicSynchronousPosition, Cia402Mode::kCyclicSynchronousVelocity,
                                Cia402Mode::kCyclicSynchronousTorque}) {
    Cia402DriveConfig c;
    c.mode = mode;
    c.rpdos = Cia402DriveConfig::DefaultRpdos(mode);
    c.quick_stop_option_code = 2;
    c.halt_option_code = 1;
    EXPECT_EQ(Joined(CheckAgainstEds(eds, c)), "") << ToString(mode);
  }
  Cia402DriveConfig c;
  c.node_id = 5;
  ApplyEdsDefaults(eds, c);
  EXPECT_EQ(c.rpdos[0].cob_id, 0x205u);
  EXPECT_EQ(c.tpdos[0].cob_id, 0x185u);
  EXPECT_EQ(c.tpdos[1].cob_id, 0x285u);
}

// The EDS describes the drive: every readable object answers an SDO read with its data type's size, and the
// identity, device type, supported modes, rated torque and strings are the EDS's default values.
TEST(CanopenEds, TheSampleEdsDescribesTheSimulatedDrive) {
  const Eds eds = Eds::Load(kEdsPath);
  test::Cia402Rig rig;
  rig.config.read_device_info = false;
  rig.Build();
  rig.drive->Configure();
  auto& sdo = rig.drive->sdo();
  int checked = 0;
  for (const auto& [key, e] : eds.entries()) {
    if (!e.readable() || !e.data_type || (e.index == 0x1003 && e.subindex > 0)) continue;  // an empty history
    const std::uint16_t t = *e.data_type;
    SCOPED_TRACE(e.section);
    if (t == canopen::datatype::kVisibleString) {
      if (e.access == "const") {
        EXPECT_EQ(sdo.UploadString(e.index, e.subindex), e.default_value);
      }
      ++checked;
      continue;
    }
    const std::uint8_t size = t == canopen::datatype::kInteger8 || t == canopen::datatype::kUnsigned8     ? 1
                              : t == canopen::datatype::kInteger16 || t == canopen::datatype::kUnsigned16 ? 2
                                                                                                          : 4;
    const std::uint32_t value = sdo.Upload(e.index, e.subindex, size);
    if (e.access == "ro" &&
        (e.index == 0x1000 || e.index == 0x1018 || e.index == 0x6502 || e.index == 0x6076 || e.index == 0x1014)) {
      EXPECT_EQ(value, eds.DefaultValue(e.index, e.subindex, 1).value());
    }
    ++checked;
  }
  EXPECT_GT(checked, 100);
  EXPECT_EQ(rig.drive->sdo_counters().aborts, 0u);
}

// CiA 306: DefaultValue is the value after reset. Every numeric object the EDS gives a DefaultValue reads back as
// that value from a drive just booted (power-on, before any configuration): the factory PDO mappings and COB-IDs,
// the statusword of Switch On Disabled, the heartbeat and consumer times.
TEST(CanopenEds, EveryDefaultValueIsWhatTheDriveHoldsAfterReset) {
  const Eds eds = Eds::Load(kEdsPath);
  test::Cia402Rig rig;
  rig.Build();
  rig.Advance(20'000'000);  // boot-up
  auto& sdo = rig.drive->sdo();
  int checked = 0;
  std::string differ;
  for (const auto& [key, e] : eds.entries()) {
    if (!e.readable() || !e.data_type || e.default_value.empty()) continue;
    if (e.index == 0x1003 && e.subindex > 0) continue;  // the history is empty after reset: nothing to read
    const std::uint16_t t = *e.data_type;
    if (t == canopen::datatype::kVisibleString) continue;  // checked by TheSampleEdsDescribesTheSimulatedDrive
    const std::uint8_t size = t == canopen::datatype::kInteger8 || t == canopen::datatype::kUnsigned8     ? 1
                              : t == canopen::datatype::kInteger16 || t == canopen::datatype::kUnsigned16 ? 2
                                                                                                          : 4;
    const std::uint32_t mask = size == 4 ? 0xFFFF'FFFFu : (1u << (8 * size)) - 1u;
    const std::uint32_t want = eds.DefaultValue(e.index, e.subindex, rig.sim_config.node_id).value() & mask;
    const std::uint32_t got = sdo.Upload(e.index, e.subindex, size) & mask;
    if (got != want) differ += fmt::format("[{}] DefaultValue 0x{:X}, after reset 0x{:X}\n", e.section, want, got);
    ++checked;
  }
  EXPECT_EQ(differ, "");
  EXPECT_GT(checked, 100);
}

/// Configures a simulated drive with `eds_text` as its EDS; returns the error (nothing must reach the drive).
std::string ConfigureWith(const std::string& eds_text, Cia402Mode mode, const std::string& name) {
  const std::string path = std::string(TELEOP_BINARY_DIR) + "/tests/" + name;
  std::ofstream(path) << eds_text;
  test::Cia402Rig rig;
  rig.config.mode = mode;
  rig.config.eds_file = path;
  rig.Build();
  std::string error = "(nothing thrown)";
  try {
    ApplyEds(rig.config);
  } catch (const Error& e) {
    error = e.what();
  }
  try {
    rig.drive->Configure();
    rig.drive->Activate();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("the EDS does not fit"), std::string::npos) << e.what();
  }
  rig.Advance(20'000'000);
  EXPECT_EQ(rig.sim->counters().nmt_commands, 0u) << "the drive was touched";
  EXPECT_EQ(rig.sim->counters().sdo_requests, 0u);
  EXPECT_EQ(rig.sim->drive_state(), cia402::DriveState::kSwitchOnDisabled);
  return error;
}

TEST(CanopenEds, AMissingObjectNamesTheFileAndTheSection) {
  const std::string e =
      ConfigureWith(Without(ReadFile(kEdsPath), "607A"), Cia402Mode::kCyclicSynchronousPosition, "missing.eds");
  EXPECT_NE(e.find("missing.eds: no section [607A] or [607Asub0] (object 0x607A, target position (position mode)), "
                   "which the client writes"),
            std::string::npos)
      << e;
}

TEST(CanopenEds, AWrongTypeNamesTheSectionAndTheKey) {
  const std::string e = ConfigureWith(WithKey(ReadFile(kEdsPath), "6060", "DataType", "0x0005"),
                                      Cia402Mode::kCyclicSynchronousTorque, "type.eds");
  EXPECT_NE(e.find("type.eds: [6060] DataType is 0x0005 (UNSIGNED8), the client uses INTEGER8 (0x0002): modes of "
                   "operation"),
            std::string::npos)
      << e;
}

TEST(CanopenEds, AModeTheEdsLacksIsRefused) {
  const std::string e = ConfigureWith(WithKey(ReadFile(kEdsPath), "6502", "DefaultValue", "0x00000200"),
                                      Cia402Mode::kCyclicSynchronousVelocity, "modes.eds");
  EXPECT_NE(e.find("modes.eds: [6502] DefaultValue 0x00000200 lacks cyclic synchronous velocity (bit 8)"),
            std::string::npos)
      << e;
}

TEST(CanopenEds, AccessMappingAndCapacityMismatchesAreEachReported) {
  std::string text = WithKey(ReadFile(kEdsPath), "6041", "AccessType", "wo");
  text = WithKey(text, "6064", "PDOMapping", "0");
  text = WithKey(text, "DeviceInfo", "NrOfTXPDO", "1");
  const std::string e = ConfigureWith(text, Cia402Mode::kCyclicSynchronousTorque, "access.eds");
  EXPECT_NE(e.find("3 problems"), std::string::npos) << e;
  EXPECT_NE(e.find("access.eds: [6041] AccessType is 'wo', the client reads it: statusword"), std::string::npos) << e;
  EXPECT_NE(e.find("access.eds: [6064] PDOMapping is 0, the configuration maps it: position actual value"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("access.eds: [DeviceInfo] NrOfTXPDO is 1, the configuration uses TPDO2"), std::string::npos) << e;
}

TEST(CanopenEds, AMalformedFileNamesTheLineOrTheKey) {
  std::string error;
  try {
    (void)Eds::Parse("[1000]\nDataType=0x0007\n[1000\n", "broken.eds");
  } catch (const Error& e) {
    error = e.what();
  }
  EXPECT_NE(error.find("EDS broken.eds: line 3"), std::string::npos) << error;
  try {
    (void)Eds::Parse("[1000]\nDataType=UNSIGNED32\n", "word.eds");
  } catch (const Error& e) {
    error = e.what();
  }
  EXPECT_EQ(error, "EDS word.eds: [1000] DataType: 'UNSIGNED32' is not a number");
  EXPECT_THROW((void)Eds::Load("/nonexistent/drive.eds"), Error);
}

TEST(CanopenEds, ANodeThatAnswersOnlySomeSdosIsAClearErrorAndNothingIsEnabled) {
  test::Cia402Rig rig;
  rig.Build();
  rig.sim->IgnoreObject(0x6502);
  std::string error;
  try {
    rig.drive->Configure();
  } catch (const Error& e) {
    error = e.what();
  }
  EXPECT_NE(error.find("SDO read of 0x6502:00 on node 1: no response within 5 ms, 4 attempts"), std::string::npos)
      << error;
  EXPECT_THROW(rig.drive->Activate(), Error);
  EXPECT_EQ(rig.sim->drive_state(), cia402::DriveState::kSwitchOnDisabled);
  EXPECT_EQ(rig.sim->nmt_state(), canopen::NmtState::kPreOperational);
}

}  // namespace
}  // namespace teleop::fieldbus
