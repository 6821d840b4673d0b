// transport::CandumpLogPort (link.can.log_path, docs/can.md): the frames a node writes and reads reach a candump -L
// file in order, through the ring and the writer thread, and every frame is either logged or counted as dropped.
#include "teleop/transport/can_log_port.hpp"

#include <gtest/gtest.h>

#include <deque>
#include <fstream>
#include <string>
#include <vector>

#include "teleop/error.hpp"
#include "teleop/transport/can_log.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::transport {
namespace {

using proto::can::CanFrame;

/// Accepts every write (refuses one with id 0x7FF: a transmission that failed); reads what the test queued.
class FakePort final : public CanPort {
 public:
  explicit FakePort(std::deque<CanFrame> incoming) : incoming_(std::move(incoming)) {}
  CanWriteStatus Write(const CanFrame& frame) noexcept override {
    return frame.id == 0x7FF ? CanWriteStatus::kBufferFull : CanWriteStatus::kOk;
  }
  bool Read(CanFrame& frame) noexcept override {
    if (incoming_.empty()) return false;
    frame = incoming_.front();
    incoming_.pop_front();
    return true;
  }
  std::string Describe() const override { return "fake"; }

 private:
  std::deque<CanFrame> incoming_;
};

CanFrame Frame(std::uint32_t id, std::uint8_t first) {
  CanFrame f{};
  f.id = id;
  f.len = 2;
  f.data[0] = first;
  f.data[1] = 0xAB;
  return f;
}

TEST(CandumpLogPort, WritesWhatTheNodeSentAndReadInOrder) {
  const teleop::test::ScopedTempDir dir("can-log-port");
  const std::string path = dir.File("can_log_port.log");
  std::uint64_t logged = 0;
  {
    CandumpLogPort port(std::make_unique<FakePort>(std::deque<CanFrame>{Frame(0x180, 1), Frame(0x181, 2)}), path,
                        "can0");
    EXPECT_EQ(port.Write(Frame(0x100, 10)), CanWriteStatus::kOk);
    CanFrame in{};
    EXPECT_TRUE(port.Read(in));
    EXPECT_EQ(port.Write(Frame(0x7FF, 11)), CanWriteStatus::kBufferFull);  // not on the bus: not logged
    EXPECT_TRUE(port.Read(in));
    EXPECT_FALSE(port.Read(in));
    EXPECT_EQ(port.Write(Frame(0x100, 12)), CanWriteStatus::kOk);
    logged = port.logged();
    EXPECT_EQ(port.logged() + port.dropped(), 4u);
    EXPECT_NE(port.Summary().find("frames logged"), std::string::npos);
  }  // the destructor drains the ring
  std::ifstream file(path);
  std::vector<std::uint32_t> ids;
  std::vector<std::uint8_t> firsts;
  for (std::string line; std::getline(file, line);) {
    CanFrame f{};
    std::uint64_t t = 0;
    std::string iface;
    ASSERT_TRUE(ParseCandumpLine(line, f, t, iface)) << line;
    EXPECT_EQ(iface, "can0");
    ids.push_back(f.id);
    firsts.push_back(f.data[0]);
  }
  EXPECT_EQ(ids.size(), logged);
  EXPECT_EQ(ids, (std::vector<std::uint32_t>{0x100, 0x180, 0x181, 0x100}));
  EXPECT_EQ(firsts, (std::vector<std::uint8_t>{10, 1, 2, 12}));
}

TEST(CandumpLogPort, AFullRingDropsAndCountsNeverBlocks) {
  const teleop::test::ScopedTempDir dir("can-log-port");
  const std::string path = dir.File("can_log_port_full.log");
  std::uint64_t logged = 0;
  constexpr int kFrames = 20000;
  {
    CandumpLogPort port(std::make_unique<FakePort>(std::deque<CanFrame>{}), path, "vcan0", 4);
    for (int i = 0; i < kFrames; ++i)
      ASSERT_EQ(port.Write(Frame(0x100, static_cast<std::uint8_t>(i))), CanWriteStatus::kOk);
    EXPECT_EQ(port.logged() + port.dropped(), static_cast<std::uint64_t>(kFrames));
    logged = port.logged();
  }
  std::ifstream file(path);
  std::uint64_t lines = 0;
  for (std::string line; std::getline(file, line);) ++lines;
  EXPECT_EQ(lines, logged);  // every logged frame is in the file, the dropped ones are not
}

TEST(CandumpLogPort, AnUnwritablePathIsRefusedAtConstruction) {
  EXPECT_THROW(CandumpLogPort(std::make_unique<FakePort>(std::deque<CanFrame>{}), "/nonexistent-dir/x.log", "can0"),
               Error);
}

}  // namespace
}  // namespace teleop::transport
