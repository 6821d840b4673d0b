// docs/protocol.md "Receiving": the order of the receive checks in the table is the order DecodeSample runs them.
// Each decode step of the table has a fault here that fails that step alone; for every pair of steps, a datagram
// with both faults must be reported under the earlier step, and the table's statuses must be the faults' statuses
// in the same order. Reordering the checks in the code or the rows in the page fails this test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "teleop/proto/codec.hpp"
#include "teleop/proto/crc.hpp"

namespace teleop::proto {
namespace {

using Bytes = std::vector<std::uint8_t>;

/// One fault: `message` edits the sample before it is encoded, `header` edits the encoded bytes (the CRC is
/// recomputed after the header edits), `wire` edits the bytes after that (CRC and length faults).
struct Fault {
  DecodeStatus status;
  std::function<void(SampleMessage&)> message;
  std::function<void(Bytes&)> header;
  std::function<void(Bytes&)> wire;
};

std::vector<Fault> DecodeSteps() {
  const auto none_m = [](SampleMessage&) {};
  const auto none_b = [](Bytes&) {};
  const double nan = std::numeric_limits<double>::quiet_NaN();
  return {
      {DecodeStatus::kTooShort, none_m, none_b, [](Bytes& b) { b.resize(20); }},                         // step 2
      {DecodeStatus::kBadMagic, none_m, [](Bytes& b) { b[0] ^= 0xFF; }, none_b},                         // 3
      {DecodeStatus::kBadVersion, none_m, [](Bytes& b) { b[wire::kVersionOffset] = 0xEE; }, none_b},     // 4
      {DecodeStatus::kBadType, none_m, [](Bytes& b) { b[wire::kTypeOffset] = 0xEE; }, none_b},           // 5
      {DecodeStatus::kBadDof, none_m, [](Bytes& b) { b[wire::kDofOffset] = 0; }, none_b},                // 6
      {DecodeStatus::kBadLength, none_m, [](Bytes& b) { b[wire::kPayloadLengthOffset] = 25; }, none_b},  // 7
      {DecodeStatus::kTooShort, none_m, none_b, [](Bytes& b) { b.pop_back(); }},                         // 8
      {DecodeStatus::kBadLength, none_m, none_b, [](Bytes& b) { b.push_back(0); }},                      // 9
      {DecodeStatus::kBadCrc, none_m, none_b, [](Bytes& b) { b[b.size() - 1] ^= 0x01; }},                // 10
      {DecodeStatus::kOutOfRange, none_m, [](Bytes& b) { b[wire::kReservedOffset] = 1; }, none_b},       // 11
      {DecodeStatus::kOutOfRange, [](SampleMessage& m) { m.flags = 0x80; }, none_b, none_b},             // 12
      {DecodeStatus::kNonFinite, [nan](SampleMessage& m) { m.force_N[0] = nan; }, none_b, none_b},       // 13
      {DecodeStatus::kOutOfRange, [](SampleMessage& m) { m.position_m[0] = 1e6; }, none_b, none_b},      // 14
  };
}

SampleMessage Valid() {
  SampleMessage m{};
  m.sender = SenderRole::kMaster;
  m.dof = 1;
  m.sequence = 7;
  m.position_m[0] = 0.01;
  m.velocity_m_per_s[0] = 0.1;
  m.force_N[0] = 1.0;
  return m;
}

/// The sample with the faults `which` applied, stage by stage, as bytes.
Bytes WithFaults(const std::vector<Fault>& steps, const std::vector<std::size_t>& which) {
  SampleMessage m = Valid();
  for (const std::size_t i : which) steps[i].message(m);
  Bytes b(MaxEncodedSampleSize());
  b.resize(EncodeSample(m, b));
  EXPECT_FALSE(b.empty());
  for (const std::size_t i : which) steps[i].header(b);
  const std::size_t crc_at = b.size() - wire::kCrcSize;
  const std::uint32_t crc = Crc32c(std::span<const std::uint8_t>(b.data(), crc_at));
  for (std::size_t k = 0; k < 4; ++k) b[crc_at + k] = static_cast<std::uint8_t>(crc >> (8 * k));
  for (const std::size_t i : which) steps[i].wire(b);
  return b;
}

DecodeStatus Decode(const Bytes& b) {
  SampleMessage out{};
  return DecodeSample(b, out);
}

TEST(ReceiveOrder, EachFaultAloneFailsItsOwnStep) {
  const auto steps = DecodeSteps();
  EXPECT_EQ(Decode(WithFaults(steps, {})), DecodeStatus::kOk);
  for (std::size_t i = 0; i < steps.size(); ++i) {
    EXPECT_EQ(Decode(WithFaults(steps, {i})), steps[i].status) << "step " << i + 2;
  }
}

TEST(ReceiveOrder, TwoFaultsAreReportedUnderTheEarlierStep) {
  const auto steps = DecodeSteps();
  for (std::size_t i = 0; i < steps.size(); ++i) {
    for (std::size_t j = i + 1; j < steps.size(); ++j) {
      if (i == 6 && j == 7) continue;  // steps 8 and 9: too few and too many bytes cannot both hold
      EXPECT_EQ(Decode(WithFaults(steps, {i, j})), steps[i].status) << "steps " << i + 2 << " and " << j + 2;
    }
  }
}

/// The status column of the numbered rows of docs/protocol.md's "Receiving" table, from step 2 to 14.
std::vector<std::string> DocumentedDecodeSteps() {
  std::ifstream in(std::string(TELEOP_SOURCE_DIR) + "/docs/protocol.md");
  std::string line;
  bool inside = false;
  std::vector<std::string> out;
  while (std::getline(in, line)) {
    if (line.rfind("## ", 0) == 0) inside = line.find("Receiving") != std::string::npos;
    if (!inside || line.rfind("| ", 0) != 0) continue;
    std::vector<std::string> cells;
    std::stringstream row(line.substr(1));
    for (std::string cell; std::getline(row, cell, '|');) cells.push_back(cell);
    if (cells.size() < 3) continue;
    int step = 0;
    try {
      step = std::stoi(cells[0]);
    } catch (const std::exception&) {
      continue;
    }
    const auto open = cells[2].find('`');
    const auto close = cells[2].find('`', open + 1);
    if (step >= 2 && step <= 14 && open != std::string::npos && close != std::string::npos) {
      out.push_back(cells[2].substr(open + 1, close - open - 1));
    }
  }
  return out;
}

TEST(ReceiveOrder, TheProtocolPageListsTheStepsInTheOrderTheCodeRunsThem) {
  const auto steps = DecodeSteps();
  const std::vector<std::string> documented = DocumentedDecodeSteps();
  ASSERT_EQ(documented.size(), steps.size()) << "docs/protocol.md: the Receiving table's steps 2..14";
  for (std::size_t i = 0; i < steps.size(); ++i) {
    EXPECT_EQ(documented[i], ToString(steps[i].status)) << "step " << i + 2;
  }
}

}  // namespace
}  // namespace teleop::proto
