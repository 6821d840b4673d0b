// proto/teleop.dbc and the codec agree: every signal's start bit, length, byte order, sign, factor, offset, min,
// max, unit and receiver; every message's identifier, length and frame format; and frames encoded by the codec
// decode through the DBC's definitions to the sample's values.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "teleop/proto/can/sample_codec.hpp"

namespace teleop::proto::can {
namespace {

struct DbcSignal {
  std::string name;
  int start_bit = 0;
  int length = 0;
  bool intel = false;
  bool is_signed = false;
  double factor = 0, offset = 0, min = 0, max = 0;
  std::string unit, receiver;
};
struct DbcMessage {
  std::uint32_t id = 0;
  std::string name, sender;
  int dlc = 0;
  int frame_format = 0;  // VFrameFormat: 0 classic standard, 14 FD standard
  std::vector<DbcSignal> signals;
};

std::map<std::uint32_t, DbcMessage> ParseDbc(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << "cannot read " << path;
  const std::regex bo(R"(^BO_ (\d+) (\w+): (\d+) (\w+)\s*$)");
  const std::regex sg(
      R"re(^ SG_ (\w+) : (\d+)\|(\d+)@([01])([+-]) \(([^,]+),([^)]+)\) \[([^|]+)\|([^\]]+)\] "([^"]*)" (\w+)\s*$)re");
  const std::regex ba(R"(^BA_ "VFrameFormat" BO_ (\d+) (\d+);\s*$)");
  std::map<std::uint32_t, DbcMessage> messages;
  DbcMessage* current = nullptr;
  std::string line;
  std::smatch m;
  while (std::getline(in, line)) {
    if (std::regex_match(line, m, bo)) {
      const auto id = static_cast<std::uint32_t>(std::stoul(m[1]));
      current = &messages[id];
      current->id = id;
      current->name = m[2];
      current->dlc = std::stoi(m[3]);
      current->sender = m[4];
    } else if (std::regex_match(line, m, sg)) {
      EXPECT_NE(current, nullptr) << line;
      if (current == nullptr) continue;
      DbcSignal s;
      s.name = m[1];
      s.start_bit = std::stoi(m[2]);
      s.length = std::stoi(m[3]);
      s.intel = m[4] == "1";
      s.is_signed = m[5] == "-";
      s.factor = std::stod(m[6]);
      s.offset = std::stod(m[7]);
      s.min = std::stod(m[8]);
      s.max = std::stod(m[9]);
      s.unit = m[10];
      s.receiver = m[11];
      current->signals.push_back(s);
    } else if (std::regex_match(line, m, ba)) {
      messages[static_cast<std::uint32_t>(std::stoul(m[1]))].frame_format = std::stoi(m[2]);
    } else if (line.rfind(" SG_", 0) == 0) {
      ADD_FAILURE() << "unparsed signal line: " << line;
    } else if (line.empty()) {
      current = nullptr;
    }
  }
  return messages;
}

// What the codec's table says slot `slot` carries in the largest layout the DBC describes (6 DOF classic, 12 FD):
// its signals, and for slot 0 the layout marker (a 1-bit unsigned signal "Layout", always 1). FD: bit positions in
// the FD frame.
std::vector<DbcSignal> SlotExpected(int slot, bool fd, const std::string& receiver) {
  std::vector<DbcSignal> out;
  const int dof = fd ? kMaxWireDof : kMaxClassicDof;
  for (const SlotSignal& s : SlotSignals(slot)) {
    if (!SignalUsed(slot, s, dof)) continue;
    const FieldScaling& sc = ScalingOf(s.kind);
    DbcSignal d;
    d.name = sc.name;
    if (s.dof_in_pair >= 0) {
      d.name += std::to_string(GlobalDof(slot, s));
    } else if (fd && s.kind == SignalKind::kCounter) {
      d.name += "_S" + std::to_string(slot);
    }
    d.start_bit = s.start_bit + (fd ? 64 * slot : 0);
    d.length = s.length;
    d.intel = true;
    d.is_signed = sc.is_signed;
    d.factor = sc.lsb;
    d.offset = 0;
    d.max = sc.is_signed ? MaxAbsValue(sc) : static_cast<double>((1 << s.length) - 1);
    d.min = sc.is_signed ? -d.max : 0.0;
    d.unit = sc.unit;
    d.receiver = receiver;
    out.push_back(d);
  }
  if (slot == 0) {
    DbcSignal marker;
    marker.name = "Layout";
    marker.start_bit = LayoutMarkerBit(dof);
    marker.length = 1;
    marker.intel = true;
    marker.factor = 1;
    marker.max = 1;
    marker.receiver = receiver;
    out.push_back(marker);
  }
  return out;
}

std::vector<DbcSignal> ExpectedSignals(bool fd, const std::string& receiver) {
  std::vector<DbcSignal> out;
  for (int slot = 0; slot < SlotCount(fd ? kMaxWireDof : kMaxClassicDof); ++slot) {
    const std::vector<DbcSignal> signals = SlotExpected(slot, fd, receiver);
    out.insert(out.end(), signals.begin(), signals.end());
  }
  return out;
}

void ExpectSameSignals(const std::vector<DbcSignal>& dbc, const std::vector<DbcSignal>& expected,
                       const std::string& where) {
  ASSERT_EQ(dbc.size(), expected.size()) << where;
  for (std::size_t i = 0; i < dbc.size(); ++i) {
    const DbcSignal& a = dbc[i];
    const DbcSignal& e = expected[i];
    SCOPED_TRACE(where + " " + e.name);
    EXPECT_EQ(a.name, e.name);
    EXPECT_EQ(a.start_bit, e.start_bit);
    EXPECT_EQ(a.length, e.length);
    EXPECT_TRUE(a.intel);
    EXPECT_EQ(a.is_signed, e.is_signed);
    EXPECT_NEAR(a.factor, e.factor, 1e-15);
    EXPECT_EQ(a.offset, 0.0);
    EXPECT_NEAR(a.min, e.min, 1e-9);
    EXPECT_NEAR(a.max, e.max, 1e-9);
    EXPECT_EQ(a.unit, e.unit);
    EXPECT_EQ(a.receiver, e.receiver);
  }
}

// The DBC's VERSION names the layout the codec speaks (a tool user can tell a layout-1 DBC from this one).
TEST(CanDbc, VersionIsTheCodecsLayoutVersion) {
  std::ifstream in(TELEOP_DBC_PATH);
  std::string first;
  std::getline(in, first);
  EXPECT_EQ(first, "VERSION \"teleop-can-" + std::to_string(kCanLayoutVersion) + "\"");
}

TEST(CanDbc, EveryMessageAndSignalMatchesTheCodecTable) {
  const auto messages = ParseDbc(TELEOP_DBC_PATH);
  const CanWireFormat defaults{};
  ASSERT_EQ(messages.size(), 10u);  // 4 classic + 1 FD per direction
  for (const SenderRole role : {SenderRole::kMaster, SenderRole::kSlave}) {
    const std::uint32_t base = BaseIdOf(defaults, role);
    const std::string sender = role == SenderRole::kMaster ? "MASTER" : "SLAVE";
    const std::string receiver = role == SenderRole::kMaster ? "SLAVE" : "MASTER";
    // Classic: the signals of slot k in message base + k.
    for (int slot = 0; slot < kMaxClassicSlots; ++slot) {
      const auto it = messages.find(base + static_cast<std::uint32_t>(slot));
      ASSERT_NE(it, messages.end()) << base + slot;
      EXPECT_EQ(it->second.dlc, 8);
      EXPECT_EQ(it->second.sender, sender);
      EXPECT_EQ(it->second.frame_format, 0);
      ExpectSameSignals(it->second.signals, SlotExpected(slot, false, receiver), it->second.name);
    }
    const auto fd = messages.find(base + kFdIdOffset);
    ASSERT_NE(fd, messages.end());
    EXPECT_EQ(static_cast<std::size_t>(fd->second.dlc),
              RoundUpToFdLength(static_cast<std::size_t>(FdDataBytes(kMaxWireDof))));
    EXPECT_EQ(fd->second.dlc, 64);           // 12 DOF fill one CAN FD frame exactly
    EXPECT_EQ(fd->second.frame_format, 14);  // StandardCAN_FD
    EXPECT_EQ(fd->second.sender, sender);
    ExpectSameSignals(fd->second.signals, ExpectedSignals(true, receiver), fd->second.name);
  }
}

double DecodeWithDbc(const DbcSignal& s, const CanFrame& f) {
  std::uint64_t raw = 0;
  for (int b = 0; b < s.length; ++b) {
    const int bit = s.start_bit + b;
    raw |= static_cast<std::uint64_t>((f.data[static_cast<std::size_t>(bit / 8)] >> (bit % 8)) & 1u) << b;
  }
  double value = static_cast<double>(raw);
  if (s.is_signed && (raw >> (s.length - 1)) != 0) value -= static_cast<double>(std::uint64_t{1} << s.length);
  return value * s.factor + s.offset;
}

// Encoded frames read through the DBC's own definitions give the sample back (what a CAN analyser shows).
TEST(CanDbc, CodecFramesDecodeThroughTheDbc) {
  const auto messages = ParseDbc(TELEOP_DBC_PATH);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  SampleMessage m{};
  m.sender = SenderRole::kSlave;
  m.flags = kFlagFault | kFlagShutdown | kFlagClutched;
  m.sequence = 11;
  for (std::size_t j = 0; j < static_cast<std::size_t>(kMaxWireDof); ++j) {
    m.position_m[j] = u(rng);
    m.velocity_m_per_s[j] = 10 * u(rng);
    m.force_N[j] = 100 * u(rng);
  }
  // Classic at its largest (6 DOF, 4 frames), FD at 6 and at its largest (12 DOF, one 64-byte frame).
  for (const auto& [fd, dof] : {std::pair{false, 6}, std::pair{true, 6}, std::pair{true, 12}}) {
    m.dof = static_cast<std::uint8_t>(dof);
    CanWireFormat f{};
    f.dof = dof;
    f.fd = fd;
    std::array<CanFrame, kMaxSlots> frames{};
    const EncodeResult r = EncodeCycle(m, f, frames);
    ASSERT_GT(r.frames, 0);
    int checked = 0;
    for (int i = 0; i < r.frames; ++i) {
      const CanFrame& frame = frames[static_cast<std::size_t>(i)];
      const auto it = messages.find(frame.id);
      ASSERT_NE(it, messages.end());
      for (const DbcSignal& s : it->second.signals) {
        if (s.start_bit >= 8 * frame.len) continue;  // the FD message's slots past this dof: not sent
        const double v = DecodeWithDbc(s, frame);
        const std::string stem = s.name.substr(0, s.name.find_first_of("0123456789_"));
        if (stem == "Counter") {
          EXPECT_EQ(v, 11.0) << s.name;
        } else if (stem == "Flags") {
          EXPECT_EQ(v, static_cast<double>(kFlagFault | kFlagShutdown | kFlagClutched));
        } else if (stem == "Layout") {
          EXPECT_EQ(v, 1.0) << "the layout marker of layout " << kCanLayoutVersion;
        } else {
          const auto j = static_cast<std::size_t>(std::stoi(s.name.substr(stem.size())));
          const double expected = stem == "Position"   ? m.position_m[j]
                                  : stem == "Velocity" ? m.velocity_m_per_s[j]
                                                       : m.force_N[j];
          EXPECT_NEAR(v, expected, s.factor / 2 + 1e-12) << s.name;
        }
        ++checked;
      }
    }
    // counters, flags, the layout marker, 3 per DOF
    EXPECT_EQ(checked, SlotCount(dof) + 1 + 1 + 3 * dof) << "fd " << fd << " dof " << dof;
  }
}

}  // namespace
}  // namespace teleop::proto::can
