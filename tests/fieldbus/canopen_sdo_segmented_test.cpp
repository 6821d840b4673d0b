// Segmented SDO (CiA 301 §7.2.4.3.3-6): golden bytes of every segmented frame written out from the standard's
// tables by hand, whole transfers against a scripted server (every byte the client sends, aborts included), the
// client's abort on each protocol error, and the simulated drive's segmented server.
//
// The frames (byte 0; bytes 1..7), from CiA 301 §7.2.4.3:
//   initiate download request   ccs=1: 001 x n(2) e s  — e=0, s=1: 0x21, bytes 4..7 the size
//   initiate download response  scs=3: 011 xxxxx       — 0x60
//   download segment request    ccs=0: 000 t n(3) c    — n = 7 - data bytes, c = 1 on the last
//   download segment response   scs=1: 001 t xxxx      — 0x20 / 0x30
//   initiate upload request     ccs=2: 010 xxxxx       — 0x40
//   initiate upload response    scs=2: 010 x n(2) e s  — e=0, s=1: 0x41, bytes 4..7 the size
//   upload segment request      ccs=3: 011 t xxxx      — 0x60 / 0x70
//   upload segment response     scs=0: 000 t n(3) c
//   abort                       cs=4:  100 xxxxx       — 0x80, the code in bytes 4..7 (LE)
// The toggle bit is 0 in the first segment and alternates; the response repeats its request's. A wrong toggle is
// abort 0x05030000, an unknown or misplaced specifier 0x05040001, a timeout 0x05040000, a length that does not
// match the one indicated 0x06070010 (CiA 301 Table "SDO abort codes").
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "cia402_test_rig.hpp"
#include "teleop/error.hpp"
#include "teleop/fieldbus/canopen_sdo.hpp"
#include "teleop/fieldbus/canopen_sdo_client.hpp"
#include "teleop/transport/can_emulated_bus.hpp"

namespace teleop::fieldbus::canopen {
namespace {

using proto::can::CanFrame;

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

CanFrame Parse(const std::string& text) {
  CanFrame f{};
  const std::size_t hash = text.find('#');
  f.id = static_cast<std::uint32_t>(std::stoul(text.substr(0, hash), nullptr, 16));
  for (std::size_t i = hash + 1; i + 1 < text.size(); i += 2) {
    f.data[f.len++] = static_cast<std::uint8_t>(std::stoul(text.substr(i, 2), nullptr, 16));
  }
  return f;
}

std::span<const std::uint8_t> Bytes(const std::string& s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

TEST(CanopenSdoSegmented, GoldenBytes) {
  // Initiate download of 10 bytes to 0x2000:00; initiate upload response of 0x1008:00 with 12 bytes.
  EXPECT_EQ(Hex(EncodeSdoInitiateDownloadSegmented(1, 0x2000, 0, 10)), "601#210020000A000000");
  EXPECT_EQ(Hex(EncodeSdoInitiateUploadSegmented(1, 0x1008, 0, 12)), "581#410810000C000000");
  // Upload segment requests: t = 0, 1.
  EXPECT_EQ(Hex(EncodeSdoUploadSegmentRequest(1, false)), "601#6000000000000000");
  EXPECT_EQ(Hex(EncodeSdoUploadSegmentRequest(5, true)), "605#7000000000000000");
  // Upload segments: "teleop " (7 bytes, t 0, n 0, c 0) and "drive" (5 bytes, t 1, n 2, c 1: 0x10|0x04|0x01).
  EXPECT_EQ(Hex(EncodeSdoUploadSegment(1, false, Bytes("teleop "), false)), "581#0074656C656F7020");
  EXPECT_EQ(Hex(EncodeSdoUploadSegment(1, true, Bytes("drive"), true)), "581#1564726976650000");
  // Download segments: "0123456" (t 0, n 0, c 0), "789" (t 1, n 4, c 1: 0x10|0x08|0x01).
  EXPECT_EQ(Hex(EncodeSdoDownloadSegment(1, false, Bytes("0123456"), false)), "601#0030313233343536");
  EXPECT_EQ(Hex(EncodeSdoDownloadSegment(1, true, Bytes("789"), true)), "601#1937383900000000");
  // An empty last segment: n 7, c 1 (0x0F).
  EXPECT_EQ(Hex(EncodeSdoDownloadSegment(1, false, {}, true)), "601#0F00000000000000");
  EXPECT_EQ(Hex(EncodeSdoDownloadSegmentResponse(1, false)), "581#2000000000000000");
  EXPECT_EQ(Hex(EncodeSdoDownloadSegmentResponse(1, true)), "581#3000000000000000");
  // More than 7 bytes are cut to 7, never spilled.
  EXPECT_EQ(Hex(EncodeSdoUploadSegment(1, false, Bytes("123456789"), false)), "581#0031323334353637");
  EXPECT_EQ(Hex(EncodeSdoAbort(0x601, 0x1008, 0, sdo_abort::kToggleBit)), "601#8008100000000305");
  EXPECT_STREQ(DescribeSdoAbort(sdo_abort::kToggleBit), "Toggle bit not alternated");
  EXPECT_STREQ(DescribeSdoAbort(sdo_abort::kNoData), "No data available");
}

TEST(CanopenSdoSegmented, DecodesEverySegmentedFrame) {
  SdoMessage m{};
  ASSERT_TRUE(DecodeSdoRequest(Parse("601#210020000A000000"), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadInitiateSegmented);
  EXPECT_EQ(m.index, 0x2000);
  EXPECT_TRUE(m.size_indicated);
  EXPECT_EQ(m.value, 10u);
  ASSERT_TRUE(DecodeSdoRequest(Parse("601#2000200000000000"), m));  // size not indicated
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadInitiateSegmented);
  EXPECT_FALSE(m.size_indicated);
  ASSERT_TRUE(DecodeSdoRequest(Parse("601#1937383900000000"), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadSegmentRequest);
  EXPECT_TRUE(m.toggle);
  EXPECT_TRUE(m.last);
  ASSERT_EQ(m.segment_size, 3);
  EXPECT_EQ(m.segment[0], '7');
  EXPECT_EQ(m.segment[2], '9');
  EXPECT_EQ(m.index, 0);  // a segment has no index
  ASSERT_TRUE(DecodeSdoRequest(Parse("601#7000000000000000"), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUploadSegmentRequest);
  EXPECT_TRUE(m.toggle);
  ASSERT_TRUE(DecodeSdoRequest(Parse("601#A400100000000000"), m));  // block upload (ccs 5): not implemented
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUnsupported);
  ASSERT_TRUE(DecodeSdoRequest(Parse("601#2208100078563412"), m));  // expedited, size not indicated: 4 bytes
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadRequest);
  EXPECT_EQ(m.size, 4);
  EXPECT_EQ(m.value, 0x1234'5678u);

  ASSERT_TRUE(DecodeSdoResponse(Parse("581#410810000C000000"), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUploadInitiateSegmented);
  EXPECT_EQ(m.index, 0x1008);
  EXPECT_EQ(m.value, 12u);
  ASSERT_TRUE(DecodeSdoResponse(Parse("581#1564726976650000"), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUploadSegmentResponse);
  EXPECT_TRUE(m.toggle);
  EXPECT_TRUE(m.last);
  EXPECT_EQ(m.segment_size, 5);
  ASSERT_TRUE(DecodeSdoResponse(Parse("581#0074656C656F7020"), m));
  EXPECT_FALSE(m.toggle);
  EXPECT_FALSE(m.last);
  EXPECT_EQ(m.segment_size, 7);
  ASSERT_TRUE(DecodeSdoResponse(Parse("581#3000000000000000"), m));
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadSegmentResponse);
  EXPECT_TRUE(m.toggle);
  ASSERT_TRUE(DecodeSdoResponse(Parse("581#C400100000000000"), m));  // block upload response (scs 6)
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUnsupported);
  EXPECT_FALSE(DecodeSdoResponse(Parse("581#00746C"), m));  // SDO frames are 8 bytes
}

/// A server that answers each expected request with its scripted response ("" = silence) and records every frame
/// the client sent, in order.
struct ScriptedRig {
  std::uint64_t now_ns = 0;
  transport::EmulatedCanBus bus{transport::EmulatedCanBusConfig{}, [this] { return now_ns; }};
  int client_node = bus.AddNode();
  int server_node = bus.AddNode();
  std::unique_ptr<transport::CanPort> client_port = bus.MakePort(client_node);
  std::unique_ptr<transport::CanPort> server_port = bus.MakePort(server_node);
  std::vector<std::pair<std::string, std::string>> script;
  std::size_t next = 0;
  std::vector<std::string> sent;
  std::unique_ptr<SdoClient> client;

  ScriptedRig() {
    SdoClientConfig c;
    c.timeout_ms = 5.0;
    c.retries = 1;
    c.backoff_initial_ms = 1.0;
    Timebase t;
    t.now_ns = [this] { return now_ns; };
    t.wait_ns = [this](std::uint64_t ns) {
      now_ns += std::max<std::uint64_t>(ns, 1000);
      Serve();
    };
    client = std::make_unique<SdoClient>(*client_port, 1, c, t);
  }
  void Serve() {
    CanFrame f{};
    while (server_port->Read(f)) {
      sent.push_back(Hex(f));
      if (next < script.size() && Hex(f) == script[next].first) {
        if (!script[next].second.empty()) {
          EXPECT_EQ(server_port->Write(Parse(script[next].second)), transport::CanWriteStatus::kOk);
        }
        ++next;
      }
    }
  }
  /// Lets the bus deliver what the client sent last (its abort, sent just before it threw).
  void Flush() {
    now_ns += 1'000'000;
    Serve();
  }
  std::vector<std::string> Requests() const {
    std::vector<std::string> r;
    for (const auto& [request, response] : script) r.push_back(request);
    return r;
  }
};

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(CanopenSdoSegmented, UploadOfADeviceNameFrameByFrame) {
  ScriptedRig rig;
  rig.script = {{"601#4008100000000000", "581#410810000C000000"},
                {"601#6000000000000000", "581#0074656C656F7020"},
                {"601#7000000000000000", "581#1564726976650000"}};
  EXPECT_EQ(rig.client->UploadString(0x1008, 0), "teleop drive");
  EXPECT_EQ(rig.sent, rig.Requests());
  EXPECT_EQ(rig.client->counters().segments, 2u);
}

TEST(CanopenSdoSegmented, DownloadOfTenBytesFrameByFrame) {
  ScriptedRig rig;
  rig.script = {{"601#210020000A000000", "581#6000200000000000"},
                {"601#0030313233343536", "581#2000000000000000"},
                {"601#1937383900000000", "581#3000000000000000"}};
  rig.client->DownloadBytes(0x2000, 0, Bytes("0123456789"));
  EXPECT_EQ(rig.sent, rig.Requests());
}

TEST(CanopenSdoSegmented, AWrongToggleIsAbortedWith05030000) {
  ScriptedRig rig;
  rig.script = {{"601#4008100000000000", "581#410810000C000000"},
                {"601#6000000000000000", "581#0074656C656F7020"},
                {"601#7000000000000000", "581#0564726976650000"}};  // t = 0 again
  const std::string e = ErrorOf([&] { (void)rig.client->UploadString(0x1008, 0); });
  rig.Flush();  // the abort the client sent before throwing
  EXPECT_NE(e.find("0x1008:00 on node 1: upload segment 2 came with toggle bit 0, expected 1"), std::string::npos) << e;
  EXPECT_NE(e.find("0x05030000 Toggle bit not alternated"), std::string::npos) << e;
  ASSERT_EQ(rig.sent.size(), 4u);
  EXPECT_EQ(rig.sent.back(), "601#8008100000000305");
  EXPECT_EQ(rig.client->counters().aborts_sent, 1u);
}

TEST(CanopenSdoSegmented, ADownloadResponseWithTheWrongToggleIsAborted) {
  ScriptedRig rig;
  rig.script = {{"601#210020000A000000", "581#6000200000000000"},
                {"601#0030313233343536", "581#2000000000000000"},
                {"601#1937383900000000", "581#2000000000000000"}};
  const std::string e = ErrorOf([&] { rig.client->DownloadBytes(0x2000, 0, Bytes("0123456789")); });
  rig.Flush();
  EXPECT_NE(e.find("0x05030000"), std::string::npos) << e;
  EXPECT_EQ(rig.sent.back(), "601#8000200000000305");
}

TEST(CanopenSdoSegmented, MoreBytesThanIndicatedAreAbortedWith06070010) {
  ScriptedRig rig;
  rig.script = {{"601#4008100000000000", "581#4108100009000000"},  // 9 indicated, 12 sent
                {"601#6000000000000000", "581#0074656C656F7020"},
                {"601#7000000000000000", "581#1564726976650000"}};
  const std::string e = ErrorOf([&] { (void)rig.client->UploadString(0x1008, 0); });
  rig.Flush();  // the abort the client sent before throwing
  EXPECT_NE(e.find("segment 2 goes past the 9 bytes indicated"), std::string::npos) << e;
  EXPECT_EQ(rig.sent.back(), "601#8008100010000706");
}

TEST(CanopenSdoSegmented, FewerBytesThanIndicatedAreAbortedWith06070010) {
  ScriptedRig rig;
  rig.script = {{"601#4008100000000000", "581#4108100014000000"},  // 20 indicated, 12 sent
                {"601#6000000000000000", "581#0074656C656F7020"},
                {"601#7000000000000000", "581#1564726976650000"}};
  const std::string e = ErrorOf([&] { (void)rig.client->UploadString(0x1008, 0); });
  rig.Flush();  // the abort the client sent before throwing
  EXPECT_NE(e.find("12 bytes received, 20 indicated"), std::string::npos) << e;
  EXPECT_EQ(rig.sent.back(), "601#8008100010000706");
}

TEST(CanopenSdoSegmented, AnExpeditedAnswerToASegmentRequestIsAbortedWith05040001) {
  ScriptedRig rig;
  rig.script = {{"601#4008100000000000", "581#410810000C000000"}, {"601#6000000000000000", "581#4308100001000000"}};
  const std::string e = ErrorOf([&] { (void)rig.client->UploadString(0x1008, 0); });
  rig.Flush();  // the abort the client sent before throwing
  EXPECT_NE(e.find("answered upload segment request 1 with command 0x43"), std::string::npos) << e;
  EXPECT_NE(e.find("0x05040001 Client/server command specifier not valid or unknown"), std::string::npos) << e;
  EXPECT_EQ(rig.sent.back(), "601#8008100001000405");
}

TEST(CanopenSdoSegmented, AnObjectLargerThanTheCallerTakesIsAbortedWith05040005) {
  ScriptedRig rig;
  rig.script = {{"601#4008100000000000", "581#410810000C000000"}};
  const std::string e = ErrorOf([&] { (void)rig.client->Upload(0x1008, 0); });  // numeric read: at most 4 bytes
  rig.Flush();
  EXPECT_NE(e.find("the drive indicated 12 bytes, at most 4 accepted"), std::string::npos) << e;
  EXPECT_EQ(rig.sent.back(), "601#8008100005000405");
}

TEST(CanopenSdoSegmented, ASegmentTimeoutIsAbortedAndTheTransferRestarted) {
  ScriptedRig rig;
  rig.script = {{"601#4008100000000000", "581#410810000C000000"},
                {"601#6000000000000000", ""},  // lost
                {"601#8008100000000405", ""},  // the client's abort: SDO protocol timed out
                {"601#4008100000000000", "581#410810000C000000"},
                {"601#6000000000000000", "581#0074656C656F7020"},
                {"601#7000000000000000", "581#1564726976650000"}};
  EXPECT_EQ(rig.client->UploadString(0x1008, 0), "teleop drive");
  EXPECT_EQ(rig.sent, rig.Requests());
  EXPECT_EQ(rig.client->counters().timeouts, 1u);
}

TEST(CanopenSdoSegmented, AServerAbortMidTransferIsReportedWithItsText) {
  ScriptedRig rig;
  rig.script = {{"601#4008100000000000", "581#410810000C000000"}, {"601#6000000000000000", "581#8008100000000008"}};
  const std::string e = ErrorOf([&] { (void)rig.client->UploadString(0x1008, 0); });
  rig.Flush();  // the abort the client sent before throwing
  EXPECT_NE(e.find("aborted during the segmented transfer: 0x08000000 General error"), std::string::npos) << e;
  EXPECT_EQ(rig.sent.size(), 2u);  // an abort is never answered
}

TEST(CanopenSdoSegmented, ANumericObjectServedSegmentedIsRead) {
  ScriptedRig rig;  // a server may answer any upload segmented, even 4 bytes
  rig.script = {{"601#4000100000000000", "581#4100100004000000"},
                {"601#6000000000000000", "581#0792010200000000"}};  // 4 bytes, n 3, c 1
  EXPECT_EQ(rig.client->Upload(0x1000, 0, 4), 0x0002'0192u);
}

TEST(CanopenSdoSegmented, BitsTheStandardLeavesUnusedAreIgnored) {
  // CiA 301 marks some bits x ("not used, always 0") and n as "only valid if e = 1 and s = 1": a receiver ignores
  // them, so a peer that sets them is still understood.
  SdoMessage m{};
  ASSERT_TRUE(DecodeSdoResponse(Parse("581#7F40600000000000"), m));  // 011 xxxxx: initiate download response
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadResponse);
  EXPECT_EQ(m.index, 0x6040);
  ASSERT_TRUE(DecodeSdoResponse(Parse("581#5D0810000C000000"), m));  // 010 1 11 0 1: segmented, n and x set
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUploadInitiateSegmented);
  EXPECT_TRUE(m.size_indicated);
  EXPECT_EQ(m.value, 12u);
  ASSERT_TRUE(DecodeSdoResponse(Parse("581#5B41600037020000"), m));  // 0x4B with x (bit 4) set: still 2 bytes
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUploadResponse);
  EXPECT_EQ(m.size, 2);
  EXPECT_EQ(m.value, 0x0237u);
  ASSERT_TRUE(DecodeSdoResponse(Parse("581#3F00000000000000"), m));  // 001 1 xxxx: download segment response
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadSegmentResponse);
  EXPECT_TRUE(m.toggle);
  ASSERT_TRUE(DecodeSdoResponse(Parse("581#9F60600030000906"), m));  // 100 xxxxx: abort
  EXPECT_EQ(m.kind, SdoMessage::Kind::kAbort);
  EXPECT_EQ(m.abort_code, 0x0609'0030u);
  ASSERT_TRUE(DecodeSdoRequest(Parse("601#5F41600000000000"), m));  // 010 xxxxx: initiate upload request
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUploadRequest);
  EXPECT_EQ(m.index, 0x6041);
  ASSERT_TRUE(DecodeSdoRequest(Parse("601#7F00000000000000"), m));  // 011 1 xxxx: upload segment request
  EXPECT_EQ(m.kind, SdoMessage::Kind::kUploadSegmentRequest);
  EXPECT_TRUE(m.toggle);
  ASSERT_TRUE(DecodeSdoRequest(Parse("601#2D0020000A000000"), m));  // 001 0 11 0 1: segmented, n set
  EXPECT_EQ(m.kind, SdoMessage::Kind::kDownloadInitiateSegmented);
  EXPECT_EQ(m.value, 10u);
}

TEST(CanopenSdoSegmented, ATimedOutRequestIsAbortedBeforeItIsRetried) {
  // A server whose initiate answer was lost may be in a segmented transfer; the abort (0x05040000) ends it, so the
  // retried initiate is not refused as a command out of place. An abort is never answered.
  ScriptedRig rig;
  rig.script = {{"601#4008100000000000", ""},  // lost
                {"601#8008100000000405", ""},
                {"601#4008100000000000", "581#410810000C000000"},
                {"601#6000000000000000", "581#0074656C656F7020"},
                {"601#7000000000000000", "581#1564726976650000"}};
  EXPECT_EQ(rig.client->UploadString(0x1008, 0), "teleop drive");
  EXPECT_EQ(rig.sent, rig.Requests());
  EXPECT_EQ(rig.client->counters().timeouts, 1u);
  EXPECT_EQ(rig.client->counters().aborts_sent, 1u);
  // A server that never answers: each of the two attempts is aborted.
  ScriptedRig dead;
  dead.script = {{"601#4041600000000000", ""},
                 {"601#8041600000000405", ""},
                 {"601#4041600000000000", ""},
                 {"601#8041600000000405", ""}};
  const std::string e = ErrorOf([&] { (void)dead.client->Upload(0x6041, 0, 2); });
  dead.Flush();
  EXPECT_NE(e.find("no response within 5 ms, 2 attempts"), std::string::npos) << e;
  EXPECT_EQ(dead.sent, dead.Requests());
}

TEST(CanopenSdoSegmented, AnExpeditedAnswerWithoutTheSizeIsTakenAtTheCallersSize) {
  // e = 1, s = 0 (0x42): "d contains unspecified number of bytes" (CiA 301); the object is in the low bytes.
  ScriptedRig rig;
  rig.script = {{"601#4061600000000000", "581#426160000AEEEEEE"}, {"601#4041600000000000", "581#4241600037020000"}};
  EXPECT_EQ(rig.client->Upload(0x6061, 0, 1), 0x0Au);
  EXPECT_EQ(rig.client->Upload(0x6041, 0), 0x0237u);  // no size expected: all 4 bytes
}

}  // namespace
}  // namespace teleop::fieldbus::canopen

namespace teleop::fieldbus {
namespace {

using proto::can::CanFrame;

std::vector<std::string> RawExchange(test::Cia402Rig& rig, std::initializer_list<std::string> requests) {
  std::vector<std::string> answers;
  for (const std::string& r : requests) {
    CanFrame f{};
    const std::size_t hash = r.find('#');
    f.id = static_cast<std::uint32_t>(std::stoul(r.substr(0, hash), nullptr, 16));
    for (std::size_t i = hash + 1; i + 1 < r.size(); i += 2) {
      f.data[f.len++] = static_cast<std::uint8_t>(std::stoul(r.substr(i, 2), nullptr, 16));
    }
    EXPECT_EQ(rig.host_port->Write(f), transport::CanWriteStatus::kOk);
    rig.Advance(1'000'000);
    CanFrame in{};
    std::string got;
    while (rig.host_port->Read(in)) {
      if (in.id != 0x581) continue;
      char buf[4];
      got = "581#";
      for (std::size_t i = 0; i < in.len; ++i) {
        std::snprintf(buf, sizeof buf, "%02X", in.data[i]);
        got += buf;
      }
    }
    answers.push_back(got);
  }
  return answers;
}

TEST(SimulatedDriveSdo, ServesTheDeviceStringsSegmentedAndTheClientLogsThemAtBringUp) {
  test::Cia402Rig rig;
  rig.sim_config.device_name = "teleop simulated CiA 402 drive";  // 30 bytes: 5 segments
  rig.sim_config.software_version = "v1";                         // 2 bytes: expedited
  rig.Build();
  rig.Advance(10'000'000);
  rig.sim->InjectFault(0x2310);  // before the bring-up: in the error history, which a reset node keeps
  rig.Advance(5'000'000);
  rig.drive->Configure();
  const Cia402DeviceInfo& info = rig.drive->device_info();
  EXPECT_EQ(info.device_name, "teleop simulated CiA 402 drive");
  EXPECT_EQ(info.hardware_version, "sim 1");
  EXPECT_EQ(info.software_version, "v1");
  EXPECT_EQ(info.vendor_id, 0x0000'0A5Au);
  ASSERT_EQ(info.error_history.size(), 1u);
  EXPECT_EQ(info.error_history[0], 0x2310u);
  EXPECT_EQ(rig.sim->counters().sdo_segments, 5u + 1u);  // 30 bytes + "sim 1" (5 bytes: 1 segment)
  EXPECT_EQ(rig.drive->sdo_counters().aborts, 0u);
  EXPECT_NE(info.Describe().find("device name 'teleop simulated CiA 402 drive'"), std::string::npos);
  EXPECT_NE(info.Describe().find("error history (newest first): 0x2310/0x0000"), std::string::npos);
}

TEST(SimulatedDriveSdo, ErrorHistoryKeepsTheNewestFirstAndClearsOnlyWithZero) {
  test::Cia402Rig rig;
  rig.config.read_device_info = false;
  rig.Build();
  rig.drive->Configure();
  rig.sim->InjectFault(0x2310);
  rig.sim->InjectFault(0x8130);
  auto& sdo = rig.drive->sdo();
  EXPECT_EQ(sdo.Upload(0x1003, 0, 1), 2u);
  EXPECT_EQ(sdo.Upload(0x1003, 1, 4), 0x8130u);
  EXPECT_EQ(sdo.Upload(0x1003, 2, 4), 0x2310u);
  const std::string no_data = [&] {
    try {
      (void)sdo.Upload(0x1003, 3, 4);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  }();
  EXPECT_NE(no_data.find("0x08000024 No data available"), std::string::npos) << no_data;
  EXPECT_THROW(sdo.Download(0x1003, 0, 1, 1), canopen::SdoAbortError);  // only 0 clears (0x06090030)
  sdo.Download(0x1003, 0, 0, 1);
  EXPECT_EQ(sdo.Upload(0x1003, 0, 1), 0u);
}

TEST(SimulatedDriveSdo, SegmentedDownloadAndReadBackOfALabel) {
  test::Cia402Rig rig;
  rig.config.read_device_info = false;
  rig.Build();
  rig.drive->Configure();
  auto& sdo = rig.drive->sdo();
  const std::string label = "left arm, joint 3, gear 1:100 ok";  // 32 bytes: 5 segments each way
  ASSERT_EQ(label.size(), 32u);
  sdo.DownloadBytes(0x2000, 0, canopen::Bytes(label));
  EXPECT_EQ(sdo.UploadString(0x2000, 0), label);
  sdo.DownloadBytes(0x2000, 0, canopen::Bytes("abc"));  // expedited
  EXPECT_EQ(sdo.UploadString(0x2000, 0), "abc");
  // Too long for the object: the server aborts the initiate (0x06070012).
  EXPECT_THROW(sdo.DownloadBytes(0x2000, 0, canopen::Bytes(label + "x")), canopen::SdoAbortError);
  // A read-only string: 0x06010002.
  EXPECT_THROW(sdo.DownloadBytes(0x1008, 0, canopen::Bytes("renamed drive")), canopen::SdoAbortError);
  // A numeric object written segmented (allowed by CiA 301): mode 10 as one byte.
  const std::uint8_t mode = 10;
  rig.drive->sdo().DownloadBytes(0x6060, 0, std::span<const std::uint8_t>(&mode, 1));
  EXPECT_EQ(rig.sim->mode_of_operation(), 10);
}

TEST(SimulatedDriveSdo, PdoCobIdsFollowCia301) {
  // No RTR on the simulated drive: bit 30 reads 1 and a 0 there is refused (0x06090030), as devices without RTR do;
  // a new identifier while the PDO is valid is refused too; invalid first, then the new one, is taken.
  test::Cia402Rig rig;
  rig.config.read_device_info = false;
  rig.Build();
  rig.drive->Configure();
  EXPECT_EQ(RawExchange(rig, {"601#4000180100000000"}), std::vector<std::string>{"581#4300180181010040"});
  EXPECT_EQ(RawExchange(rig, {"601#2300180181010000"}), std::vector<std::string>{"581#8000180130000906"});
  EXPECT_EQ(RawExchange(rig, {"601#2300180191010040"}), std::vector<std::string>{"581#8000180130000906"});
  EXPECT_EQ(RawExchange(rig, {"601#23001801810100C0", "601#23001801910100C0", "601#2300180191010040"}),
            (std::vector<std::string>{"581#6000180100000000", "581#6000180100000000", "581#6000180100000000"}));
  EXPECT_EQ(RawExchange(rig, {"601#4000180100000000"}), std::vector<std::string>{"581#4300180191010040"});
}

TEST(SimulatedDriveSdo, TheServerAbortsEveryProtocolErrorWithTheStandardsCode) {
  test::Cia402Rig rig;
  rig.config.read_device_info = false;
  rig.Build();
  rig.drive->Configure();
  // A segment request with no transfer: command not valid (0x05040001).
  EXPECT_EQ(RawExchange(rig, {"601#6000000000000000"}), std::vector<std::string>{"581#8000000001000405"});
  // Upload of the device name, then a segment request with the wrong toggle: 0x05030000.
  EXPECT_EQ(RawExchange(rig, {"601#4008100000000000", "601#7000000000000000"}),
            (std::vector<std::string>{"581#410810001E000000", "581#8008100000000305"}));
  // Download of 10 bytes to the label, last segment short of the size: 0x06070010.
  EXPECT_EQ(RawExchange(rig, {"601#210020000A000000", "601#0030313233343536", "601#1B37380000000000"}),
            (std::vector<std::string>{"581#6000200000000000", "581#2000000000000000", "581#8000200010000706"}));
  // A download segment during an upload: 0x05040001 naming the transfer's object.
  EXPECT_EQ(RawExchange(rig, {"601#4008100000000000", "601#0030313233343536"}),
            (std::vector<std::string>{"581#410810001E000000", "581#8008100001000405"}));
  // A client that goes silent mid-transfer: 0x05040000 after the server's timeout (1 s).
  EXPECT_EQ(RawExchange(rig, {"601#4008100000000000"}), std::vector<std::string>{"581#410810001E000000"});
  rig.Advance(1'100'000'000);
  CanFrame in{};
  std::string timeout;
  while (rig.host_port->Read(in)) {
    if (in.id == 0x581 && in.data[0] == 0x80)
      timeout = canopen::DescribeSdoAbort(in.data[4] | in.data[5] << 8 | in.data[6] << 16 |
                                          static_cast<std::uint32_t>(in.data[7]) << 24);
  }
  EXPECT_EQ(timeout, "SDO protocol timed out");
  // Block upload: not implemented, 0x05040001.
  EXPECT_EQ(RawExchange(rig, {"601#A408100000000000"}), std::vector<std::string>{"581#8008100001000405"});
}

}  // namespace
}  // namespace teleop::fieldbus
