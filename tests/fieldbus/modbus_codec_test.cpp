// Register words <-> SI values: golden words for every type and word order, scaling, rounding, clamping.

#include "teleop/fieldbus/modbus_codec.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

namespace teleop::fieldbus {
namespace {

ModbusPoint Reg(ModbusValueType type, double scale = 1.0, double offset = 0.0,
                ModbusWordOrder order = ModbusWordOrder::kHighWordFirst) {
  ModbusPoint p;
  p.name = "p";
  p.table = ModbusTable::kHoldingRegister;
  p.type = type;
  p.scale = scale;
  p.offset = offset;
  p.word_order = order;
  return p;
}

TEST(ModbusCodec, GoldenWordsForEveryType) {
  std::uint16_t w[2] = {0, 0};
  EXPECT_EQ(EncodePoint(Reg(ModbusValueType::kUint16), 65535.0, w), ModbusEncodeStatus::kOk);
  EXPECT_EQ(w[0], 0xFFFF);
  EXPECT_EQ(EncodePoint(Reg(ModbusValueType::kInt16), -2.0, w), ModbusEncodeStatus::kOk);
  EXPECT_EQ(w[0], 0xFFFE);
  EXPECT_EQ(EncodePoint(Reg(ModbusValueType::kUint32), 0x12345678, w), ModbusEncodeStatus::kOk);
  EXPECT_EQ(w[0], 0x1234);
  EXPECT_EQ(w[1], 0x5678);
  EXPECT_EQ(EncodePoint(Reg(ModbusValueType::kUint32, 1.0, 0.0, ModbusWordOrder::kLowWordFirst), 0x12345678, w),
            ModbusEncodeStatus::kOk);
  EXPECT_EQ(w[0], 0x5678);
  EXPECT_EQ(w[1], 0x1234);
  EXPECT_EQ(EncodePoint(Reg(ModbusValueType::kInt32), -1500.0, w), ModbusEncodeStatus::kOk);
  EXPECT_EQ(w[0], 0xFFFF);
  EXPECT_EQ(w[1], 0xFA24);

  const std::uint16_t s16[1] = {0x8000};
  EXPECT_EQ(DecodePoint(Reg(ModbusValueType::kInt16), s16), -32768.0);
  EXPECT_EQ(DecodePoint(Reg(ModbusValueType::kUint16), s16), 32768.0);
  const std::uint16_t s32[2] = {0xFFD9, 0xDA60};
  EXPECT_EQ(DecodePoint(Reg(ModbusValueType::kInt32), s32), -2500000.0);
  EXPECT_EQ(DecodePoint(Reg(ModbusValueType::kUint32), s32), 4292467296.0);
  const std::uint16_t swapped[2] = {0xDA60, 0xFFD9};
  EXPECT_EQ(DecodePoint(Reg(ModbusValueType::kInt32, 1.0, 0.0, ModbusWordOrder::kLowWordFirst), swapped), -2500000.0);
}

TEST(ModbusCodec, ScaleAndOffsetRoundTripWithinHalfACount) {
  const ModbusPoint p = Reg(ModbusValueType::kInt32, 0.001, -5.0);  // mNm counts, -5 Nm at raw 0
  std::uint16_t w[2] = {0, 0};
  for (double v = -40.0; v <= 40.0; v += 0.0137) {
    ASSERT_EQ(EncodePoint(p, v, w), ModbusEncodeStatus::kOk);
    EXPECT_NEAR(DecodePoint(p, w), v, 0.0005 + 1e-12) << v;  // half a count
  }
  // Rounds to nearest, not toward zero.
  ASSERT_EQ(EncodePoint(Reg(ModbusValueType::kInt16, 0.1), -0.26, w), ModbusEncodeStatus::kOk);
  EXPECT_EQ(w[0], static_cast<std::uint16_t>(-3));
}

TEST(ModbusCodec, OutOfRangeClampsAndNonFiniteWritesTheSafeValue) {
  std::uint16_t w[2] = {0, 0};
  EXPECT_EQ(EncodePoint(Reg(ModbusValueType::kInt16), 40000.0, w), ModbusEncodeStatus::kClamped);
  EXPECT_EQ(w[0], 0x7FFF);
  EXPECT_EQ(EncodePoint(Reg(ModbusValueType::kUint16), -1.0, w), ModbusEncodeStatus::kClamped);
  EXPECT_EQ(w[0], 0x0000);
  EXPECT_EQ(EncodePoint(Reg(ModbusValueType::kInt32), -1e12, w), ModbusEncodeStatus::kClamped);
  EXPECT_EQ(w[0], 0x8000);
  EXPECT_EQ(w[1], 0x0000);
  ModbusPoint p = Reg(ModbusValueType::kInt16, 0.01);
  p.safe_value = 1.5;
  EXPECT_EQ(EncodePoint(p, std::numeric_limits<double>::quiet_NaN(), w), ModbusEncodeStatus::kNonFinite);
  EXPECT_EQ(w[0], 150);
  EXPECT_EQ(EncodePoint(p, -std::numeric_limits<double>::infinity(), w), ModbusEncodeStatus::kNonFinite);
  EXPECT_EQ(w[0], 150);
}

TEST(ModbusCodec, BitsAreZeroOrOne) {
  ModbusPoint coil;
  coil.table = ModbusTable::kCoil;
  std::uint16_t w[2] = {7, 7};
  EXPECT_EQ(EncodePoint(coil, 0.49, w), ModbusEncodeStatus::kOk);
  EXPECT_EQ(w[0], 0);
  EXPECT_EQ(EncodePoint(coil, 1.0, w), ModbusEncodeStatus::kOk);
  EXPECT_EQ(w[0], 1);
  EXPECT_EQ(RegisterCount(coil), 1);
  coil.table = ModbusTable::kDiscreteInput;
  const std::uint16_t on[1] = {1};
  EXPECT_EQ(DecodePoint(coil, on), 1.0);
}

}  // namespace
}  // namespace teleop::fieldbus
