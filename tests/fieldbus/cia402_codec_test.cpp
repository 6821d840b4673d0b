// The CiA 402 cycle codec (teleop/fieldbus/cia402_codec.hpp) alone, no bus: golden bytes of the RPDO of each cyclic
// synchronous mode and of the default TPDOs (the same bytes docs/cia402-bringup.log shows), SI <-> drive units with
// sign and saturation, a TPDO of the wrong length refused, and the layout's checks.
#include "teleop/fieldbus/cia402_codec.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "teleop/fieldbus/cia402_drive.hpp"

namespace teleop::fieldbus {
namespace {

using proto::can::CanFrame;
namespace codec = cia402_codec;

std::string Hex(const CanFrame& f) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%03X#", static_cast<unsigned>(f.id));
  std::string s = buf;
  for (std::size_t i = 0; i < f.len; ++i) {
    std::snprintf(buf, sizeof buf, "%02X", f.data[i]);
    s += buf;
  }
  return s;
}

CanFrame Frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  CanFrame f{};
  f.id = id;
  for (const std::uint8_t b : bytes) f.data[f.len++] = b;
  return f;
}

Cia402PdoLayout Layout(Cia402Mode mode, std::uint8_t node_id) {
  Cia402PdoLayout l;
  const auto rpdos = Cia402DriveConfig::DefaultRpdos(mode);
  const auto tpdos = Cia402DriveConfig::DefaultTpdos();
  EXPECT_EQ(Cia402PdoLayout::Make(mode, rpdos, tpdos, node_id, l), "");
  return l;
}

std::string Rpdo1(const Cia402PdoLayout& l, std::uint16_t controlword, std::uint32_t target_raw) {
  std::array<CanFrame, 4> frames{};
  EXPECT_TRUE(codec::EncodeRpdos(l, controlword, target_raw, frames));
  EXPECT_EQ(l.rpdo_count, 1);
  return Hex(frames[0]);
}

TEST(Cia402Codec, RpdoGoldenBytesOfEachMode) {
  Cia402Scaling s;  // rated 1 N·m, 4096 counts and units per rad
  const auto torque = static_cast<std::uint16_t>(codec::TorqueToPerMille(0.1, s));
  EXPECT_EQ(Rpdo1(Layout(Cia402Mode::kCyclicSynchronousTorque, 1), 0x000F, torque), "201#0F006400");
  s.position_rad_per_count = 1.0 / 1048576.0;  // 2^20 counts per rad: 1.01 rad = 1059061.76 -> 0x001028F6
  const auto position = static_cast<std::uint32_t>(codec::PositionToCounts(1.01, s));
  EXPECT_EQ(Rpdo1(Layout(Cia402Mode::kCyclicSynchronousPosition, 3), 0x000F, position), "203#0F00F6281000");
  const auto velocity = static_cast<std::uint32_t>(codec::VelocityToUnits(-2.0, Cia402Scaling{}));
  EXPECT_EQ(Rpdo1(Layout(Cia402Mode::kCyclicSynchronousVelocity, 1), 0x010F, velocity), "201#0F0100E0FFFF");
  // Quick stop (0x0002) with torque 0, and the sign of a joint mounted the other way.
  Cia402Scaling reversed;
  reversed.sign = -1.0;
  reversed.rated_torque_Nm = 2.5;
  const auto minus = static_cast<std::uint16_t>(codec::TorqueToPerMille(0.5, reversed));
  EXPECT_EQ(Rpdo1(Layout(Cia402Mode::kCyclicSynchronousTorque, 127), 0x0002, minus), "27F#020038FF");  // -200 ‰
}

TEST(Cia402Codec, TpdoGoldenBytesDecodeToSi) {
  const Cia402PdoLayout l = Layout(Cia402Mode::kCyclicSynchronousTorque, 1);
  Cia402PdoValues values{};
  int pdo = -1;
  // TPDO1: statusword 0x1237 (Operation Enabled, follows the command), position 4096 counts.
  ASSERT_EQ(codec::DecodeTpdo(l, Frame(0x181, {0x37, 0x12, 0x00, 0x10, 0x00, 0x00}), values, pdo),
            Cia402TpdoResult::kStored);
  EXPECT_EQ(pdo, 0);
  // TPDO2: velocity -4096 units, torque actual -100 ‰.
  ASSERT_EQ(codec::DecodeTpdo(l, Frame(0x281, {0x00, 0xF0, 0xFF, 0xFF, 0x9C, 0xFF}), values, pdo),
            Cia402TpdoResult::kStored);
  EXPECT_EQ(pdo, 1);
  EXPECT_EQ(codec::Statusword(l, values), 0x1237);
  Cia402Scaling s;
  s.rated_torque_Nm = 2.0;
  Cia402Measured m = codec::Measured(l, values, s);
  EXPECT_DOUBLE_EQ(m.position_rad, 1.0);
  EXPECT_DOUBLE_EQ(m.velocity_rad_per_s, -1.0);
  EXPECT_DOUBLE_EQ(m.torque_Nm, -0.2);
  EXPECT_TRUE(m.torque_mapped);
  s.sign = -1.0;
  m = codec::Measured(l, values, s);
  EXPECT_DOUBLE_EQ(m.position_rad, -1.0);
  EXPECT_DOUBLE_EQ(m.torque_Nm, 0.2);
}

TEST(Cia402Codec, AWrongLengthOrAnotherFrameIsNeverMisread) {
  const Cia402PdoLayout l = Layout(Cia402Mode::kCyclicSynchronousTorque, 1);
  Cia402PdoValues values{};
  values[0][0] = 0x0237;
  int pdo = -1;
  EXPECT_EQ(codec::DecodeTpdo(l, Frame(0x181, {0x37, 0x12, 0x00, 0x10, 0x00}), values, pdo),
            Cia402TpdoResult::kRejected);
  EXPECT_EQ(codec::DecodeTpdo(l, Frame(0x182, {0x37, 0x12, 0x00, 0x10, 0x00, 0x00}), values, pdo),
            Cia402TpdoResult::kNotTpdo);
  CanFrame extended = Frame(0x181, {0x37, 0x12, 0x00, 0x10, 0x00, 0x00});
  extended.extended = true;
  EXPECT_EQ(codec::DecodeTpdo(l, extended, values, pdo), Cia402TpdoResult::kNotTpdo);
  EXPECT_EQ(codec::Statusword(l, values), 0x0237);  // untouched
  EXPECT_EQ(pdo, -1);
}

TEST(Cia402Codec, UnitsRoundAndSaturateAtTheObjectsRange) {
  const Cia402Scaling s;
  EXPECT_EQ(codec::TorqueToPerMille(0.0004, s), 0);
  EXPECT_EQ(codec::TorqueToPerMille(-0.0006, s), -1);
  EXPECT_EQ(codec::TorqueToPerMille(1e9, s), 32767);
  EXPECT_EQ(codec::TorqueToPerMille(-1e9, s), -32768);
  EXPECT_EQ(codec::TorqueToPerMille(std::nan(""), s), 0);
  EXPECT_EQ(codec::PositionToCounts(1e12, s), 2147483647);
  EXPECT_EQ(codec::VelocityToUnits(-1e12, s), -2147483647);
  EXPECT_DOUBLE_EQ(codec::PositionFromCounts(codec::PositionToCounts(0.5, s), s), 0.5);
  EXPECT_DOUBLE_EQ(codec::TorqueFromPerMille(codec::TorqueToPerMille(-0.25, s), s), -0.25);
}

TEST(Cia402Codec, TheLayoutNamesWhatIsMissingOrTwice) {
  Cia402PdoLayout l;
  const auto tpdos = Cia402DriveConfig::DefaultTpdos();
  const auto torque = Cia402DriveConfig::DefaultRpdos();
  EXPECT_EQ(Cia402PdoLayout::Make(Cia402Mode::kCyclicSynchronousPosition, torque, tpdos, 1, l),
            "position mode: rpdos must map the controlword 0x6040 (16 bits) and the target position 0x607A (32 bits)");
  auto twice = Cia402DriveConfig::DefaultRpdos();
  twice.push_back(twice[0]);
  twice[1].number = 2;
  EXPECT_EQ(Cia402PdoLayout::Make(Cia402Mode::kCyclicSynchronousTorque, twice, tpdos, 1, l),
            "object 0x6040 mapped twice");
  auto same_cob = tpdos;
  same_cob[1].cob_id = 0x181;
  EXPECT_EQ(Cia402PdoLayout::Make(Cia402Mode::kCyclicSynchronousTorque, torque, same_cob, 1, l),
            "PDO COB-ID 0x181 used twice");
  auto no_velocity = tpdos;
  no_velocity.pop_back();
  EXPECT_NE(Cia402PdoLayout::Make(Cia402Mode::kCyclicSynchronousTorque, torque, no_velocity, 1, l)
                .find("tpdos must map the statusword 0x6041"),
            std::string::npos);
}

}  // namespace
}  // namespace teleop::fieldbus
