// Golden bytes of every CANopen frame the client and the simulated drive exchange (CiA 301 §7.2: NMT, heartbeat,
// SYNC, EMCY, expedited SDO requests/responses/abort, PDOs), written out from the standard by hand, and the
// decoders' refusal of anything else.
#include "teleop/fieldbus/canopen_frames.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "teleop/error.hpp"
#include "teleop/fieldbus/canopen_heartbeat_producer.hpp"
#include "teleop/fieldbus/canopen_pdo.hpp"
#include "teleop/fieldbus/canopen_sdo.hpp"
#include "teleop/fieldbus/cia402_state_machine.hpp"
#include "teleop/transport/can_emulated_bus.hpp"

namespace teleop::fieldbus::canopen {
namespace {

/// "ID#DATA" as candump prints a classic 11-bit frame.
std::string Hex(const CanFrame& f) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%03X#", static_cast<unsigned>(f.id));
  std::string s = buf;
  for (std::size_t i = 0; i < f.len; ++i) {
    std::snprintf(buf, sizeof buf, "%02X", f.data[i]);
    s += buf;
  }
  EXPECT_FALSE(f.extended || f.fd || f.error || f.remote) << s;
  return s;
}

CanFrame Frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  CanFrame f{};
  f.id = id;
  for (const std::uint8_t b : bytes) f.data[f.len++] = b;
  return f;
}

TEST(CanopenFrames, NmtGoldenBytes) {
  EXPECT_EQ(Hex(EncodeNmt(NmtCommand::kStart, 1)), "000#0101");
  EXPECT_EQ(Hex(EncodeNmt(NmtCommand::kStop, 2)), "000#0202");
  EXPECT_EQ(Hex(EncodeNmt(NmtCommand::kEnterPreOperational, 0)), "000#8000");
  EXPECT_EQ(Hex(EncodeNmt(NmtCommand::kResetNode, 5)), "000#8105");
  EXPECT_EQ(Hex(EncodeNmt(NmtCommand::kResetCommunication, 127)), "000#827F");
  NmtCommand c{};
  std::uint8_t node = 0;
  ASSERT_TRUE(DecodeNmt(Frame(0x000, {0x81, 0x05}), c, node));
  EXPECT_EQ(c, NmtCommand::kResetNode);
  EXPECT_EQ(node, 5);
  EXPECT_FALSE(DecodeNmt(Frame(0x000, {0x03, 0x01}), c, node));  // no such command
  EXPECT_FALSE(DecodeNmt(Frame(0x000, {0x01, 0x80}), c, node));  // node 128
  EXPECT_FALSE(DecodeNmt(Frame(0x000, {0x01}), c, node));        // short
  EXPECT_FALSE(DecodeNmt(Frame(0x001, {0x01, 0x01}), c, node));  // not COB-ID 0
}

TEST(CanopenFrames, HeartbeatGoldenBytes) {
  EXPECT_EQ(Hex(EncodeHeartbeat(1, NmtState::kBootUp)), "701#00");
  EXPECT_EQ(Hex(EncodeHeartbeat(1, NmtState::kPreOperational)), "701#7F");
  EXPECT_EQ(Hex(EncodeHeartbeat(1, NmtState::kOperational)), "701#05");
  EXPECT_EQ(Hex(EncodeHeartbeat(127, NmtState::kStopped)), "77F#04");
  std::uint8_t node = 0;
  NmtState s{};
  ASSERT_TRUE(DecodeHeartbeat(Frame(0x705, {0x05}), node, s));
  EXPECT_EQ(node, 5);
  EXPECT_EQ(s, NmtState::kOperational);
  EXPECT_FALSE(DecodeHeartbeat(Frame(0x700, {0x05}), node, s));        // node 0
  EXPECT_FALSE(DecodeHeartbeat(Frame(0x705, {0x06}), node, s));        // no such state
  EXPECT_FALSE(DecodeHeartbeat(Frame(0x705, {0x05, 0x00}), node, s));  // 2 bytes
  EXPECT_FALSE(DecodeHeartbeat(Frame(0x685, {0x05}), node, s));
}

TEST(CanopenFrames, SyncGoldenBytes) {
  EXPECT_EQ(Hex(EncodeSync()), "080#");
  EXPECT_EQ(Hex(EncodeSync(0x080, 3)), "080#03");
  std::uint8_t counter = 9;
  ASSERT_TRUE(DecodeSync(Frame(0x080, {}), 0x080, counter));
  EXPECT_EQ(counter, 0);
  ASSERT_TRUE(DecodeSync(Frame(0x080, {7}), 0x080, counter));
  EXPECT_EQ(counter, 7);
  EXPECT_FALSE(DecodeSync(Frame(0x080, {7, 8}), 0x080, counter));
  EXPECT_FALSE(DecodeSync(Frame(0x081, {}), 0x080, counter));
}

TEST(CanopenFrames, EmergencyGoldenBytes) {
  Emergency e{};
  e.error_code = emcy::kOvercurrent;
  e.error_register = 0x03;
  e.manufacturer = {0xAA, 0, 0, 0, 0x55};
  EXPECT_EQ(Hex(EncodeEmergency(1, e)), "081#102303AA00000055");
  EXPECT_EQ(Hex(EncodeEmergency(2, Emergency{})), "082#0000000000000000");  // error reset
  std::uint8_t node = 0;
  Emergency d{};
  ASSERT_TRUE(DecodeEmergency(Frame(0x0A0, {0x30, 0x81, 0x11, 1, 2, 3, 4, 5}), node, d));
  EXPECT_EQ(node, 0x20);
  EXPECT_EQ(d.error_code, emcy::kHeartbeatError);
  EXPECT_EQ(d.error_register, 0x11);
  EXPECT_EQ(d.manufacturer[4], 5);
  EXPECT_STREQ(DescribeEmergencyCode(0x8130), "heartbeat/life guard error");
  EXPECT_STREQ(DescribeEmergencyCode(0x2310), "overcurrent");
  EXPECT_FALSE(DecodeEmergency(Frame(0x080, {0, 0, 0, 0, 0, 0, 0, 0}), node, d));  // that is SYNC's COB-ID
  EXPECT_FALSE(DecodeEmergency(Frame(0x081, {0, 0, 0}), node, d));
}

TEST(CanopenSdo, RequestGoldenBytes) {
  EXPECT_EQ(Hex(EncodeSdoUploadRequest(1, 0x6041, 0)), "601#4041600000000000");
  EXPECT_EQ(Hex(EncodeSdoUploadRequest(3, 0x1A00, 2)), "603#40001A0200000000");
  EXPECT_EQ(Hex(EncodeSdoDownloadRequest(1, 0x6060, 0, 10, 1)), "601#2F6060000A000000");
  EXPECT_EQ(Hex(EncodeSdoDownloadRequest(1, 0x6040, 0, 0x000F, 2)), "601#2B4060000F000000");
  EXPECT_EQ(Hex(EncodeSdoDownloadRequest(1, 0x1800, 1, 0x8000'0181, 4)), "601#2300180181010080");
  EXPECT_EQ(Hex(EncodeSdoDownloadRequest(1, 0x1016, 1, 0x007F'012C, 3)), "601#271610012C017F00");
  // A value wider than its size is cut to the size, never spilled.
  EXPECT_EQ(Hex(EncodeSdoDownloadRequest(1, 0x6071, 0, 0xFFFF'FF38, 2)), "601#2B71600038FF0000");
  SdoMessage m{};
  ASSERT_TRUE(DecodeSdoRequest(Frame(0x601, {0x2B, 0x40, 0x60, 0x00, 0x0F, 0x00, 0x00, 0x00}), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadRequest);
  EXPECT_EQ(m.index, 0x6040);
  EXPECT_EQ(m.size, 2);
  EXPECT_EQ(m.value, 0x000Fu);
  ASSERT_TRUE(DecodeSdoRequest(Frame(0x601, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUploadRequest);
  ASSERT_TRUE(DecodeSdoRequest(Frame(0x601, {0x21, 0x40, 0x60, 0x00, 9, 0, 0, 0}), m));  // segmented download
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadInitiateSegmented);  // canopen_sdo_segmented_test.cpp
  ASSERT_TRUE(DecodeSdoRequest(Frame(0x601, {0xC0, 0x40, 0x60, 0x00, 9, 0, 0, 0}), m));  // block download
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUnsupported);
  EXPECT_FALSE(DecodeSdoRequest(Frame(0x601, {0x40, 0x41, 0x60}), m));  // short
}

TEST(CanopenSdo, ResponseAndAbortGoldenBytes) {
  EXPECT_EQ(Hex(EncodeSdoUploadResponse(1, 0x6041, 0, 0x0237, 2)), "581#4B41600037020000");
  EXPECT_EQ(Hex(EncodeSdoUploadResponse(1, 0x1000, 0, 0x0002'0192, 4)), "581#4300100092010200");
  EXPECT_EQ(Hex(EncodeSdoUploadResponse(1, 0x6061, 0, 10, 1)), "581#4F6160000A000000");
  EXPECT_EQ(Hex(EncodeSdoDownloadResponse(1, 0x6040, 0)), "581#6040600000000000");
  EXPECT_EQ(Hex(EncodeSdoAbort(0x581, 0x6060, 0, sdo_abort::kValueRange)), "581#8060600030000906");
  EXPECT_EQ(Hex(EncodeSdoAbort(0x601, 0x1A00, 1, sdo_abort::kTimeout)), "601#80001A0100000405");
  SdoMessage m{};
  ASSERT_TRUE(DecodeSdoResponse(Frame(0x581, {0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0xEE, 0xEE}), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUploadResponse);
  EXPECT_EQ(m.size, 2);
  EXPECT_EQ(m.value, 0x0237u);  // bytes beyond the size are ignored
  ASSERT_TRUE(DecodeSdoResponse(Frame(0x581, {0x80, 0x60, 0x60, 0x00, 0x30, 0x00, 0x09, 0x06}), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kAbort);
  EXPECT_EQ(m.abort_code, 0x0609'0030u);
  EXPECT_STREQ(DescribeSdoAbort(m.abort_code), "Invalid value for parameter (download only)");
  EXPECT_STREQ(DescribeSdoAbort(0x0602'0000), "Object does not exist in the object dictionary");
  EXPECT_STREQ(DescribeSdoAbort(0x1234'5678), "unknown abort code");
  ASSERT_TRUE(DecodeSdoResponse(Frame(0x581, {0x60, 0x40, 0x60, 0x00, 0, 0, 0, 0}), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadResponse);
  ASSERT_TRUE(DecodeSdoResponse(Frame(0x581, {0x41, 0x08, 0x10, 0x00, 20, 0, 0, 0}), m));  // segmented upload
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUploadInitiateSegmented);  // canopen_sdo_segmented_test.cpp
  ASSERT_TRUE(DecodeSdoResponse(Frame(0x581, {0xC4, 0x08, 0x10, 0x00, 20, 0, 0, 0}), m));  // block upload
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUnsupported);
  CanFrame fd = Frame(0x581, {0x60, 0x40, 0x60, 0x00, 0, 0, 0, 0});
  fd.fd = true;
  EXPECT_FALSE(DecodeSdoResponse(fd, m));
}

PdoMapping Map(int number, std::initializer_list<PdoEntry> entries) {
  PdoMapping m{};
  m.number = number;
  for (const PdoEntry& e : entries) m.entries[static_cast<std::size_t>(m.entry_count++)] = e;
  return m;
}

TEST(CanopenPdo, RpdoAndTpdoGoldenBytes) {
  const PdoMapping rpdo1 = Map(1, {{0x6040, 0, 16}, {0x6071, 0, 16}});
  EXPECT_EQ(rpdo1.entries[0].MappingValue(), 0x6040'0010u);
  EXPECT_EQ(rpdo1.entries[1].MappingValue(), 0x6071'0010u);
  EXPECT_EQ(PdoEntry::FromMappingValue(0x6064'0020u), (PdoEntry{0x6064, 0, 32}));
  EXPECT_EQ(PdoLength(rpdo1), 4);
  EXPECT_EQ(PdoCobId(rpdo1, false, 1), 0x201u);
  CanFrame f{};
  const std::array<std::uint32_t, 2> rx{0x000F, static_cast<std::uint16_t>(std::int16_t{200})};
  ASSERT_TRUE(PackPdo(rpdo1, 0x201, rx, f));
  EXPECT_EQ(Hex(f), "201#0F00C800");
  const std::array<std::uint32_t, 2> neg{0x0002, static_cast<std::uint16_t>(std::int16_t{-200})};
  ASSERT_TRUE(PackPdo(rpdo1, 0x201, neg, f));
  EXPECT_EQ(Hex(f), "201#020038FF");

  const PdoMapping tpdo1 = Map(1, {{0x6041, 0, 16}, {0x6064, 0, 32}});
  const PdoMapping tpdo2 = Map(2, {{0x606C, 0, 32}, {0x6077, 0, 16}});
  EXPECT_EQ(PdoCobId(tpdo2, true, 1), 0x281u);
  const std::array<std::uint32_t, 2> t1{0x1237, 0xFFFF'FFFF};
  ASSERT_TRUE(PackPdo(tpdo1, 0x181, t1, f));
  EXPECT_EQ(Hex(f), "181#3712FFFFFFFF");
  std::array<std::uint32_t, 2> out{};
  ASSERT_TRUE(UnpackPdo(tpdo2, Frame(0x281, {0x00, 0x10, 0x00, 0x00, 0xFB, 0xFF}), out));
  EXPECT_EQ(SignExtend(out[0], 32), 4096);
  EXPECT_EQ(SignExtend(out[1], 16), -5);
  // A factory mapping of another length is refused, never misread.
  EXPECT_FALSE(UnpackPdo(tpdo2, Frame(0x281, {0x00, 0x10, 0x00, 0x00}), out));
  EXPECT_FALSE(UnpackPdo(tpdo2, Frame(0x281, {0x00, 0x10, 0x00, 0x00, 0xFB, 0xFF, 0x00}), out));
}

TEST(CanopenPdo, MappingChecks) {
  EXPECT_EQ(CheckPdoMapping(Map(1, {{0x6040, 0, 16}})), PdoMappingStatus::kOk);
  EXPECT_EQ(CheckPdoMapping(Map(5, {{0x6040, 0, 16}})), PdoMappingStatus::kBadNumber);
  EXPECT_EQ(CheckPdoMapping(Map(1, {})), PdoMappingStatus::kBadCount);
  EXPECT_EQ(CheckPdoMapping(Map(1, {{0x6040, 0, 12}})), PdoMappingStatus::kBadEntryLength);
  EXPECT_EQ(CheckPdoMapping(Map(1, {{0x6064, 0, 32}, {0x606C, 0, 32}, {0x6041, 0, 16}})), PdoMappingStatus::kTooLong);
  PdoMapping m = Map(1, {{0x6040, 0, 16}});
  m.cob_id = 0x581;  // an SDO response identifier
  EXPECT_EQ(CheckPdoMapping(m), PdoMappingStatus::kBadCobId);
  m.cob_id = 0x222;
  EXPECT_EQ(CheckPdoMapping(m), PdoMappingStatus::kOk);
  EXPECT_EQ(PdoCobId(m, false, 1), 0x222u);
  m.transmission_type = 0;
  EXPECT_EQ(CheckPdoMapping(m), PdoMappingStatus::kBadTransmission);
  EXPECT_EQ(SignExtend(0x80, 8), -128);
  EXPECT_EQ(SignExtend(0x7F, 8), 127);
  EXPECT_EQ(SignExtend(0xFFFF'8000u, 16), -32768);
}

TEST(CanopenCobIds, PredefinedConnectionSet) {
  EXPECT_EQ(cob::DefaultTpdo(1, 1), 0x181u);
  EXPECT_EQ(cob::DefaultTpdo(4, 0x7F), 0x4FFu);
  EXPECT_EQ(cob::DefaultRpdo(1, 1), 0x201u);
  EXPECT_EQ(cob::DefaultRpdo(4, 0x7F), 0x57Fu);
  EXPECT_EQ(cob::DefaultRpdo(5, 1), 0u);
  EXPECT_TRUE(IsValidNodeId(1));
  EXPECT_TRUE(IsValidNodeId(127));
  EXPECT_FALSE(IsValidNodeId(0));
  EXPECT_FALSE(IsValidNodeId(128));
}

// The host's heartbeat for the drives' consumers (CiA 301): 0x700 + node, one byte, 05 Operational; the first at once,
// then one per period; and the consumer entry of 0x1016 sub n: node in bits 16..23, time in ms in bits 0..15.
TEST(HeartbeatProducer, SendsTheHostHeartbeatOncePerPeriod) {
  std::uint64_t now_ns = 0;
  transport::EmulatedCanBus bus{transport::EmulatedCanBusConfig{}, [&now_ns] { return now_ns; }};
  auto host = bus.MakePort(bus.AddNode());
  auto monitor = bus.MakePort(bus.AddNode(), transport::CanReceiveOptions::Everything());
  HeartbeatProducer producer(*host, 127, 100.0);
  std::vector<std::uint64_t> sent_at_ms;
  int received = 0;
  for (std::uint64_t ms = 0; ms <= 250; ++ms) {
    now_ns = ms * 1'000'000;
    const std::uint64_t before = producer.counters().sent;
    ASSERT_EQ(producer.Service(now_ns), transport::CanWriteStatus::kOk);
    if (producer.counters().sent != before) sent_at_ms.push_back(ms);
    bus.Run();
    proto::can::CanFrame f{};
    while (monitor->Read(f)) {
      EXPECT_EQ(f.id, 0x77Fu);
      ASSERT_EQ(f.len, 1u);
      EXPECT_EQ(f.data[0], 0x05);
      ++received;
    }
  }
  EXPECT_EQ(sent_at_ms, (std::vector<std::uint64_t>{0, 100, 200}));
  EXPECT_EQ(received, 3);
  EXPECT_EQ(ConsumerHeartbeatEntry(127, 300), 0x007F012Cu);
  EXPECT_EQ(ConsumerHeartbeatEntry(1, 0), 0x00010000u);
  EXPECT_THROW(HeartbeatProducer(*host, 0, 100.0), Error);
  EXPECT_THROW(HeartbeatProducer(*host, 128, 100.0), Error);
  EXPECT_THROW(HeartbeatProducer(*host, 127, 0.0), Error);
}

}  // namespace
}  // namespace teleop::fieldbus::canopen
