// The MIT-mode motor codec (proto/can/mit_motor.hpp) against golden bytes worked out by hand from the published
// packing (the MIT Cheetah controller's pack_cmd/unpack_reply, Damiao's DM-J manual): docs/mit-motors.md.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>

#include "teleop/proto/can/bus_load.hpp"
#include "teleop/proto/can/mit_motor.hpp"

namespace teleop::proto::can::mit {
namespace {

// DM-J4310: P_MAX 12.5 rad, V_MAX 30 rad/s, T_MAX 10 N·m (the vendor's defaults).
constexpr MotorRanges kDm4310{12.5, 30.0, 10.0, 500.0, 5.0};

std::array<std::uint8_t, 8> Bytes(const CanFrame& f) {
  std::array<std::uint8_t, 8> b{};
  for (std::size_t i = 0; i < 8; ++i) b[i] = f.data[i];
  return b;
}

CanFrame Frame(std::uint32_t id, std::array<std::uint8_t, 8> bytes) {
  CanFrame f;
  f.id = id;
  f.len = 8;
  for (std::size_t i = 0; i < 8; ++i) f.data[i] = bytes[i];
  return f;
}

TEST(MitMotorCodec, TheZeroCommandIsTheWellKnownMidScaleFrame) {
  // Midpoints: 12.5·65535/25 = 32767.5 -> 0x7FFF; 30·4095/60 = 2047.5 -> 0x7FF; Kp = Kd = 0; 10·4095/20 -> 0x7FF.
  CanFrame f;
  const EncodeResult r = EncodeCommand(Command{}, kDm4310, 0x01, f);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.clamped, 0);
  EXPECT_EQ(f.id, 0x01U);
  EXPECT_EQ(f.len, 8);
  EXPECT_FALSE(f.extended);
  EXPECT_EQ(Bytes(f), (std::array<std::uint8_t, 8>{0x7F, 0xFF, 0x7F, 0xF0, 0x00, 0x00, 0x07, 0xFF}));
}

TEST(MitMotorCodec, RangeEndsMapToAllZerosAndAllOnes) {
  CanFrame f;
  ASSERT_TRUE(EncodeCommand(Command{-12.5, -30.0, 0.0, 0.0, -10.0}, kDm4310, 0x02, f).ok);
  EXPECT_EQ(Bytes(f), (std::array<std::uint8_t, 8>{}));
  ASSERT_TRUE(EncodeCommand(Command{12.5, 30.0, 500.0, 5.0, 10.0}, kDm4310, 0x02, f).ok);
  EXPECT_EQ(Bytes(f), (std::array<std::uint8_t, 8>{0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF}));
}

TEST(MitMotorCodec, FieldsSitInTheirNibbles) {
  // Kp 250 -> 250·4095/500 = 2047.5 -> 0x7FF; Kd 1.25 -> 1023.75 -> 0x3FF; v = 15 rad/s -> 45·4095/60 = 3071.25 ->
  // 0xBFF; p = 6.25 -> 18.75·65535/25 = 49151.25 -> 0xBFFF; torque 5 -> 15·4095/20 = 3071.25 -> 0xBFF.
  CanFrame f;
  const EncodeResult r = EncodeCommand(Command{6.25, 15.0, 250.0, 1.25, 5.0}, kDm4310, 0x07, f);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(Bytes(f), (std::array<std::uint8_t, 8>{0xBF, 0xFF, 0xBF, 0xF7, 0xFF, 0x3F, 0xFB, 0xFF}));
  // The motor's side: each field back within one step, never above what was sent (truncation).
  Command back;
  ASSERT_TRUE(DecodeCommand(f, kDm4310, back));
  EXPECT_NEAR(back.position_rad, 49151.0 * 25.0 / 65535.0 - 12.5, 1e-12);
  EXPECT_NEAR(back.velocity_rad_per_s, 3071.0 * 60.0 / 4095.0 - 30.0, 1e-12);
  EXPECT_NEAR(back.kp_Nm_per_rad, 2047.0 * 500.0 / 4095.0, 1e-12);
  EXPECT_NEAR(back.kd_Nm_s_per_rad, 1023.0 * 5.0 / 4095.0, 1e-12);
  EXPECT_NEAR(back.torque_Nm, 3071.0 * 20.0 / 4095.0 - 10.0, 1e-12);
  CanFrame special;
  EncodeSpecial(Special::kEnable, 0x07, special);
  EXPECT_FALSE(DecodeCommand(special, kDm4310, back));
}

TEST(MitMotorCodec, OutOfRangeIsClampedAndFlaggedNonFiniteIsRefused) {
  CanFrame f;
  EncodeResult r = EncodeCommand(Command{20.0, -31.0, 600.0, -1.0, 11.0}, kDm4310, 0x01, f);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.clamped, kFieldPosition | kFieldVelocity | kFieldKp | kFieldKd | kFieldTorque);
  EXPECT_EQ(f.data[0], 0xFF);  // position at +P_MAX
  EXPECT_EQ(f.data[2], 0x00);  // velocity at -V_MAX
  CanFrame untouched = f;
  r = EncodeCommand(Command{0, 0, 0, 0, std::nan("")}, kDm4310, 0x01, untouched);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(Bytes(untouched), Bytes(f));
  r = EncodeCommand(Command{std::numeric_limits<double>::infinity(), 0, 0, 0, 0}, kDm4310, 0x01, untouched);
  EXPECT_FALSE(r.ok);
  MotorRanges bad = kDm4310;
  bad.torque_max_Nm = 0;
  EXPECT_FALSE(EncodeCommand(Command{}, bad, 0x01, untouched).ok);
}

TEST(MitMotorCodec, ACommandNeverSpellsASpecialFrame) {
  // Every field at its top and a torque of 9.995 N·m (12 bits 0xFFD) would read FF..FF FD: "disable". The torque
  // moves down to 0xFFA (9.9756 N·m).
  CanFrame f;
  const EncodeResult r = EncodeCommand(Command{12.5, 30.0, 500.0, 5.0, 9.995}, kDm4310, 0x01, f);
  ASSERT_TRUE(r.ok);
  EXPECT_TRUE(r.nudged);
  EXPECT_EQ(f.data[7], 0xFA);
  EXPECT_FALSE(DecodeSpecial(f).has_value());
  Feedback fb;
  const CanFrame echo =
      Frame(0x11, {0x01, f.data[0], f.data[1], f.data[2],
                   static_cast<std::uint8_t>((f.data[3] & 0xF0) | (f.data[6] & 0x0F)), f.data[7], 0, 0});
  ASSERT_EQ(DecodeFeedback(echo, kDm4310, 0x11, 0x01, fb), DecodeStatus::kOk);
  EXPECT_NEAR(fb.torque_Nm, 4090.0 * 20.0 / 4095.0 - 10.0, 1e-12);
  ASSERT_TRUE(EncodeCommand(Command{12.5, 30.0, 500.0, 5.0, 9.0}, kDm4310, 0x01, f).ok);
  EXPECT_FALSE(DecodeSpecial(f).has_value());
}

TEST(MitMotorCodec, SpecialFrames) {
  CanFrame f;
  EncodeSpecial(Special::kEnable, 0x03, f);
  EXPECT_EQ(f.id, 0x03U);
  EXPECT_EQ(Bytes(f), (std::array<std::uint8_t, 8>{0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFC}));
  EncodeSpecial(Special::kDisable, 0x03, f);
  EXPECT_EQ(f.data[7], 0xFD);
  EncodeSpecial(Special::kSetZero, 0x03, f);
  EXPECT_EQ(f.data[7], 0xFE);
  EncodeSpecial(Special::kClearError, 0x03, f);
  EXPECT_EQ(f.data[7], 0xFB);
  EXPECT_EQ(DecodeSpecial(f), Special::kClearError);
  f.data[7] = 0xFF;
  EXPECT_FALSE(DecodeSpecial(f).has_value());
  EncodeSpecial(Special::kEnable, 0x03, f, /*fd=*/true);
  EXPECT_TRUE(f.fd);
  EXPECT_EQ(f.len, 8);
}

TEST(MitMotorCodec, FeedbackDecodesEveryField) {
  // Motor 1 enabled, position 0x8000, velocity 0x800, torque 0x800, MOS 40 °C, rotor 35 °C.
  const CanFrame f = Frame(0x11, {0x11, 0x80, 0x00, 0x80, 0x08, 0x00, 0x28, 0x23});
  Feedback fb;
  ASSERT_EQ(DecodeFeedback(f, kDm4310, 0x11, 0x01, fb), DecodeStatus::kOk);
  EXPECT_EQ(fb.status, 1);
  EXPECT_EQ(fb.esc_id_low, 1);
  EXPECT_NEAR(fb.position_rad, 32768.0 * 25.0 / 65535.0 - 12.5, 1e-12);
  EXPECT_NEAR(fb.velocity_rad_per_s, 2048.0 * 60.0 / 4095.0 - 30.0, 1e-12);
  EXPECT_NEAR(fb.torque_Nm, 2048.0 * 20.0 / 4095.0 - 10.0, 1e-12);
  EXPECT_EQ(fb.mos_temperature_C, 40.0);
  EXPECT_EQ(fb.rotor_temperature_C, 35.0);
  // The ends: all zeros is -P_MAX, -V_MAX, -T_MAX; all ones (bar D0) is +P_MAX, +V_MAX, +T_MAX.
  ASSERT_EQ(DecodeFeedback(Frame(0x11, {0x01, 0, 0, 0, 0, 0, 0, 0}), kDm4310, 0x11, 0x01, fb), DecodeStatus::kOk);
  EXPECT_DOUBLE_EQ(fb.position_rad, -12.5);
  EXPECT_DOUBLE_EQ(fb.velocity_rad_per_s, -30.0);
  EXPECT_DOUBLE_EQ(fb.torque_Nm, -10.0);
  ASSERT_EQ(DecodeFeedback(Frame(0x11, {0x01, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0}), kDm4310, 0x11, 0x01, fb),
            DecodeStatus::kOk);
  EXPECT_DOUBLE_EQ(fb.position_rad, 12.5);
  EXPECT_DOUBLE_EQ(fb.velocity_rad_per_s, 30.0);
  EXPECT_DOUBLE_EQ(fb.torque_Nm, 10.0);
}

TEST(MitMotorCodec, EveryErrorCodeIsNamedAndClassified) {
  struct Code {
    std::uint8_t code;
    const char* name;
    bool fault;
  };
  const Code codes[] = {{0x0, "disabled", false},
                        {0x1, "enabled", false},
                        {0x8, "over-voltage", true},
                        {0x9, "under-voltage", true},
                        {0xA, "over-current", true},
                        {0xB, "MOS over-temperature", true},
                        {0xC, "coil over-temperature", true},
                        {0xD, "communication lost", true},
                        {0xE, "overload", true}};
  for (const Code& c : codes) {
    Feedback fb;
    const std::uint8_t d0 = static_cast<std::uint8_t>(0x05 | (c.code << 4));
    ASSERT_EQ(DecodeFeedback(Frame(0x15, {d0, 0x80, 0, 0x80, 0x08, 0, 0, 0}), kDm4310, 0x15, 0x05, fb),
              DecodeStatus::kOk);
    EXPECT_EQ(fb.status, c.code);
    EXPECT_EQ(StatusName(fb.status), c.name);
    EXPECT_EQ(IsFault(fb.status), c.fault) << c.name;
  }
  for (const int c : {0x2, 0x3, 0x4, 0x5, 0x6, 0x7, 0xF}) {
    const auto code = static_cast<std::uint8_t>(c);
    EXPECT_EQ(StatusName(code), "unknown error code");
    EXPECT_TRUE(IsFault(code));
  }
}

TEST(MitMotorCodec, FramesOfTheWrongIdLengthOrMotorAreRefused) {
  Feedback fb;
  fb.position_rad = 42.0;
  const std::array<std::uint8_t, 8> good{0x11, 0x80, 0x00, 0x80, 0x08, 0x00, 0x28, 0x23};
  EXPECT_EQ(DecodeFeedback(Frame(0x12, good), kDm4310, 0x11, 0x01, fb), DecodeStatus::kWrongId);
  CanFrame short_frame = Frame(0x11, good);
  short_frame.len = 6;
  EXPECT_EQ(DecodeFeedback(short_frame, kDm4310, 0x11, 0x01, fb), DecodeStatus::kWrongLength);
  CanFrame extended = Frame(0x11, good);
  extended.extended = true;
  EXPECT_EQ(DecodeFeedback(extended, kDm4310, 0x11, 0x01, fb), DecodeStatus::kWrongId);
  EXPECT_EQ(DecodeFeedback(Frame(0x11, good), kDm4310, 0x11, 0x02, fb), DecodeStatus::kWrongMotor);
  EXPECT_EQ(fb.position_rad, 42.0);  // untouched on refusal
}

TEST(MitMotorCodec, ParameterFrames) {
  CanFrame f;
  EncodeParameter(Parameter{0x01, ParameterOp::kRead, static_cast<std::uint8_t>(Register::kPositionMax), 123}, f);
  EXPECT_EQ(f.id, 0x7FFU);
  EXPECT_EQ(Bytes(f), (std::array<std::uint8_t, 8>{0x01, 0x00, 0x33, 0x15, 0, 0, 0, 0}));
  // TMAX = 10.0f: IEEE-754 0x41200000, little-endian.
  EncodeParameter(Parameter{0x01, ParameterOp::kWrite, static_cast<std::uint8_t>(Register::kTorqueMax),
                            Parameter::FromFloat(10.0F)},
                  f);
  EXPECT_EQ(Bytes(f), (std::array<std::uint8_t, 8>{0x01, 0x00, 0x55, 0x17, 0x00, 0x00, 0x20, 0x41}));
  // TIMEOUT = 20 ms = 400 counts of 50 µs.
  EncodeParameter(Parameter{0x102, ParameterOp::kWrite, static_cast<std::uint8_t>(Register::kTimeout), 400}, f);
  EXPECT_EQ(Bytes(f), (std::array<std::uint8_t, 8>{0x02, 0x01, 0x55, 0x09, 0x90, 0x01, 0x00, 0x00}));
  EncodeParameter(Parameter{0x01, ParameterOp::kSave, 0, 0}, f);
  EXPECT_EQ(Bytes(f), (std::array<std::uint8_t, 8>{0x01, 0x00, 0xAA, 0x01, 0, 0, 0, 0}));
  // An answer on the master id: VMAX = 30.0f (0x41F00000).
  const auto p = DecodeParameter(Frame(0x11, {0x01, 0x00, 0x33, 0x16, 0x00, 0x00, 0xF0, 0x41}));
  ASSERT_TRUE(p.has_value());
  EXPECT_EQ(p->esc_id, 0x01);
  EXPECT_EQ(p->op, ParameterOp::kRead);
  EXPECT_EQ(p->reg, static_cast<std::uint8_t>(Register::kVelocityMax));
  EXPECT_TRUE(IsFloatRegister(p->reg));
  EXPECT_FLOAT_EQ(p->FloatValue(), 30.0F);
  EXPECT_FALSE(DecodeParameter(Frame(0x11, {0x01, 0x00, 0x44, 0x16, 0, 0, 0, 0})).has_value());
  EXPECT_FALSE(IsFloatRegister(static_cast<std::uint8_t>(Register::kTimeout)));
}

TEST(MitMotorCodec, RoundTripWithinOneStepOverRandomCommands) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 2000; ++i) {
    const double p = 12.5 * u(rng);
    const double v = 30.0 * u(rng);
    const double t = 10.0 * u(rng);
    CanFrame cmd;
    ASSERT_TRUE(EncodeCommand(Command{p, v, 0, 0, t}, kDm4310, 1, cmd).ok);
    // The feedback frame packs p, v, t like the command (shifted one byte): decode the command's fields that way.
    const CanFrame fb_frame =
        Frame(0x11, {0x11, cmd.data[0], cmd.data[1], cmd.data[2],
                     static_cast<std::uint8_t>((cmd.data[3] & 0xF0) | (cmd.data[6] & 0x0F)), cmd.data[7], 0, 0});
    Feedback fb;
    ASSERT_EQ(DecodeFeedback(fb_frame, kDm4310, 0x11, 1, fb), DecodeStatus::kOk);
    EXPECT_LE(std::abs(fb.position_rad - p), 25.0 / 65535.0 + 1e-12);
    EXPECT_LE(std::abs(fb.velocity_rad_per_s - v), 60.0 / 4095.0 + 1e-12);
    EXPECT_LE(std::abs(fb.torque_Nm - t), 20.0 / 4095.0 + 1e-12);
    EXPECT_LE(fb.position_rad, p + 1e-12);  // truncation: never above the value sent
  }
}

TEST(MitMotorCodec, SevenMotorsAtOneKilohertzNeedCanFdOrMoreBuses) {
  // Classic 1 Mbit/s: a command and a feedback of 8 bytes, 11-bit ids, 135 bits each with worst-case stuffing.
  MitBusLoad b = ComputeMitBusLoad(7, 1000.0, false, false, 1e6, 5e6, 0.8);
  EXPECT_NEAR(b.exchange_time_s, 270e-6, 1e-15);
  EXPECT_NEAR(b.load, 7 * 270e-6 * 1000.0, 1e-12);  // 1.89: does not fit
  EXPECT_EQ(b.max_motors, 2);                       // 2 · 0.27 = 0.54 <= 0.8 < 0.81
  // CAN FD, 1 Mbit/s arbitration, 5 Mbit/s data phase: the same 8 bytes.
  const CanBitrates fd{1e6, 5e6};
  b = ComputeMitBusLoad(7, 1000.0, true, true, 1e6, 5e6, 0.8);
  EXPECT_NEAR(b.exchange_time_s, 2 * FrameTime_s(true, true, false, 8, fd), 1e-15);
  EXPECT_LT(b.load, 0.8);
  EXPECT_EQ(b.max_motors, 7);
  // At 500 Hz on classic CAN, 5 motors fit within 80 % (0.675).
  EXPECT_EQ(ComputeMitBusLoad(7, 500.0, false, false, 1e6, 5e6, 0.8).max_motors, 5);
}

}  // namespace
}  // namespace teleop::proto::can::mit
