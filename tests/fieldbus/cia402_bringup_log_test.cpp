// docs/cia402-bringup.log: a candump -L log of the client bringing the simulated drive up and running 20 cycles
// of torque mode, written by transport::CandumpLogWriter from a monitor node of the emulated bus (manual clock,
// so the log is the same on every run). The test regenerates it and compares it with the committed file; set
// TELEOP_UPDATE_GOLDEN=1 to rewrite the committed one. It also checks the candump format itself (writer/parser
// round trip, FD, error and remote frames).
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "cia402_test_rig.hpp"

namespace teleop::fieldbus {
namespace {

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(CandumpLog, FormatsAndParsesEveryFrameKind) {
  using proto::can::CanFrame;
  std::array<char, transport::kMaxCandumpLineBytes> buf{};
  auto line = [&](const CanFrame& f, std::uint64_t t) {
    const std::size_t n = transport::FormatCandumpLine(f, t, "vcan0", buf);
    return std::string(buf.data(), n);
  };
  CanFrame f{};
  f.id = 0x601;
  f.len = 8;
  f.data = {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0};
  EXPECT_EQ(line(f, 1'234'567'891'000), "(0000001234.567891) vcan0 601#4041600000000000\n");
  CanFrame empty{};
  empty.id = 0x080;
  EXPECT_EQ(line(empty, 0), "(0000000000.000000) vcan0 080#\n");
  CanFrame ext{};
  ext.id = 0x1ABCDE0;
  ext.extended = true;
  ext.len = 1;
  ext.data[0] = 0xFF;
  EXPECT_EQ(line(ext, 0), "(0000000000.000000) vcan0 01ABCDE0#FF\n");
  CanFrame fd{};
  fd.id = 0x184;
  fd.fd = true;
  fd.brs = true;
  fd.len = 12;
  fd.data[0] = 0x11;
  EXPECT_EQ(line(fd, 0), "(0000000000.000000) vcan0 184##1110000000000000000000000\n");
  CanFrame rtr{};
  rtr.id = 0x701;
  rtr.remote = true;
  EXPECT_EQ(line(rtr, 0), "(0000000000.000000) vcan0 701#R\n");
  CanFrame err{};
  err.error = true;
  err.error_class = proto::can::kErrBusOff;
  err.len = 8;
  EXPECT_EQ(line(err, 0), "(0000000000.000000) vcan0 20000040#0000000000000000\n");
  for (const CanFrame& g : {f, empty, ext, fd, rtr, err}) {
    CanFrame back{};
    std::uint64_t t = 0;
    std::string iface;
    const std::string text = line(g, 42'000);
    ASSERT_TRUE(transport::ParseCandumpLine(text, back, t, iface)) << text;
    EXPECT_EQ(t, 42'000u);
    EXPECT_EQ(iface, "vcan0");
    EXPECT_EQ(line(back, t), text);
  }
  // candump's own FD line from a kernel ≥ 6.0 (FDF flag 0x04 in the flags nibble) reads too.
  CanFrame back{};
  std::uint64_t t = 0;
  std::string iface;
  ASSERT_TRUE(transport::ParseCandumpLine("(1700000000.000001) vcan0 184##5112233445566778899AABBCC", back, t, iface));
  EXPECT_TRUE(back.fd && back.brs);
  EXPECT_EQ(back.len, 12);
  for (const char* bad :
       {"", "(12.5) vcan0 123#00", "(0000000001.000000) vcan0 123#0", "(0000000001.000000) vcan0 1234#00",
        "(0000000001.000000) vcan0 123#001122334455667788", "(0000000001.000000) vcan0 184##10011223344556677889900",
        "(0000000001.000000) vcan0 12G#00", "(0000000001.000000)vcan0 123#00"}) {
    EXPECT_FALSE(transport::ParseCandumpLine(bad, back, t, iface)) << bad;
  }
  // A buffer too small for the line writes nothing.
  std::array<char, 20> small{};
  EXPECT_EQ(transport::FormatCandumpLine(f, 0, "vcan0", small), 0u);
}

TEST(CandumpLog, Cia402BringUpMatchesTheCommittedLog) {
  const std::string produced = std::string(TELEOP_BINARY_DIR) + "/tests/cia402-bringup.log";
  const std::string committed = std::string(TELEOP_SOURCE_DIR) + "/docs/cia402-bringup.log";
  {
    test::Cia402Rig rig;
    rig.Build();
    rig.log = std::make_unique<transport::CandumpLogWriter>(produced, "vcan0");
    rig.BringUp();
    for (int k = 0; k < 20; ++k) ASSERT_NE(rig.Cycle(0.1).read, Cia402Status::kStale);
    rig.Advance(1'000'000);
    EXPECT_TRUE(rig.drive->Deactivate());
    rig.Advance(1'000'000);
    EXPECT_EQ(rig.log->write_errors(), 0u);
    EXPECT_EQ(rig.log->lines(), rig.monitored);
  }
  const std::string log = Slurp(produced);
  // Every line parses, and the bring-up is there in order: reset, boot-up, mode 10, NMT start, enable, SYNC/PDOs.
  std::istringstream lines(log);
  std::string text;
  int n = 0;
  while (std::getline(lines, text)) {
    proto::can::CanFrame f{};
    std::uint64_t t = 0;
    std::string iface;
    ASSERT_TRUE(transport::ParseCandumpLine(text, f, t, iface)) << text;
    ++n;
  }
  EXPECT_GT(n, 100);
  std::size_t at = 0;
  for (const char* step : {" 000#8101", " 701#00", " 601#2F6060000A000000", " 000#0101", " 601#2B4060000F000000",
                           " 201#0F006400", " 080#", " 181#37", " 281#"}) {
    const std::size_t found = log.find(step, at);
    ASSERT_NE(found, std::string::npos) << "missing, or out of order: " << step;
    at = found;
  }
  if (const char* update = std::getenv("TELEOP_UPDATE_GOLDEN"); update != nullptr && std::string(update) == "1") {
    std::ofstream(committed) << log;
  }
  EXPECT_EQ(log, Slurp(committed)) << "the bring-up changed: check " << produced
                                   << " and rerun with TELEOP_UPDATE_GOLDEN=1 to update docs/cia402-bringup.log";
}

}  // namespace
}  // namespace teleop::fieldbus
