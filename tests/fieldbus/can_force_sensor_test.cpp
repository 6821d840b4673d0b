// The CAN force-sensor node: golden bytes of its frame, refusal of other lengths, the invalid value, staleness, and
// the client against the simulated node on the emulated bus (SYNC-triggered). Also the bus-level SYNC producer.
#include "teleop/fieldbus/can_force_sensor.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "teleop/error.hpp"
#include "teleop/fieldbus/canopen_sync_producer.hpp"
#include "teleop/fieldbus/simulated_can_force_sensor.hpp"
#include "teleop/transport/can_emulated_bus.hpp"

namespace teleop::fieldbus {
namespace {

using canopen::CanFrame;

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

TEST(CanForceSensorCodec, GoldenBytesInt16) {
  CanForceSensorConfig c;  // 0x190, 2 axes, int16, 0.01 N
  CanFrame f;
  const std::array<double, 2> force{12.34, -5.0};
  ASSERT_TRUE(EncodeForceFrame(c, force, f));
  EXPECT_EQ(Hex(f), "190#D2040CFE");
  std::array<double, 2> back{};
  ASSERT_TRUE(DecodeForceFrame(c, f, back));
  EXPECT_DOUBLE_EQ(back[0], 12.34);
  EXPECT_DOUBLE_EQ(back[1], -5.0);
}

TEST(CanForceSensorCodec, GoldenBytesInt32ThreeAxesRefusedTwoAccepted) {
  CanForceSensorConfig c;
  c.cob_id = 0x2A5;
  c.encoding = ForceSensorEncoding::kInt32;
  c.scale_N_per_count = 0.001;
  c.offset_N = {1.0, 0.0, 0.0, 0.0};
  CanFrame f;
  const std::array<double, 2> force{1.0 + 70.0, -0.001};  // raw 70000, -1
  ASSERT_TRUE(EncodeForceFrame(c, force, f));
  EXPECT_EQ(Hex(f), "2A5#70110100FFFFFFFF");
  std::array<double, 2> back{};
  ASSERT_TRUE(DecodeForceFrame(c, f, back));
  EXPECT_NEAR(back[0], 71.0, 1e-12);
  EXPECT_NEAR(back[1], -0.001, 1e-12);
  c.axes = 3;
  EXPECT_THROW(c.Validate(), Error);  // 12 bytes do not fit a classic frame
}

TEST(CanForceSensorCodec, InvalidValueClampAndWrongFramesRefused) {
  CanForceSensorConfig c;
  c.axes = 3;
  CanFrame f;
  const std::array<double, 3> force{NAN, 1e6, -1e6};
  int clamped = 0;
  ASSERT_TRUE(EncodeForceFrame(c, force, f, &clamped));
  EXPECT_EQ(Hex(f), "190#0080FF7F0180");  // invalid, +32767, -32767
  EXPECT_EQ(clamped, 2);
  std::array<double, 3> back{};
  ASSERT_TRUE(DecodeForceFrame(c, f, back));
  EXPECT_TRUE(std::isnan(back[0]));
  EXPECT_DOUBLE_EQ(back[1], 327.67);
  CanFrame shorter = f;
  shorter.len = 4;
  EXPECT_FALSE(DecodeForceFrame(c, shorter, back));  // another mapping is refused, never misread
  CanFrame other = f;
  other.id = 0x191;
  EXPECT_FALSE(DecodeForceFrame(c, other, back));
  CanFrame fd = f;
  fd.fd = true;
  EXPECT_FALSE(DecodeForceFrame(c, fd, back));
  const std::array<double, 2> too_few{1.0, 2.0};
  EXPECT_FALSE(EncodeForceFrame(c, too_few, f));
}

TEST(CanForceSensorConfig, RefusesBadValues) {
  const auto bad = [](auto mutate) {
    CanForceSensorConfig c;
    mutate(c);
    EXPECT_THROW(c.Validate("x"), Error);
  };
  bad([](CanForceSensorConfig& c) { c.cob_id = 0; });
  bad([](CanForceSensorConfig& c) { c.cob_id = 0x800; });
  bad([](CanForceSensorConfig& c) { c.cob_id = 0x080; });
  bad([](CanForceSensorConfig& c) { c.axes = 0; });
  bad([](CanForceSensorConfig& c) { c.axes = 5; });
  bad([](CanForceSensorConfig& c) { c.scale_N_per_count = 0.0; });
  bad([](CanForceSensorConfig& c) { c.scale_N_per_count = std::nan(""); });
  bad([](CanForceSensorConfig& c) { c.stale_after_ms = 0.0; });
  CanForceSensorConfig ok;
  EXPECT_NO_THROW(ok.Validate());
}

struct SensorBus {
  std::uint64_t now_ns = 0;
  transport::EmulatedCanBus bus{transport::EmulatedCanBusConfig{}, [this] { return now_ns; }};
  CanForceSensorConfig config;
  std::unique_ptr<transport::CanPort> host_port;
  std::unique_ptr<transport::CanPort> node_port;
  std::unique_ptr<transport::CanPort> monitor;
  std::unique_ptr<canopen::SyncProducer> sync;
  std::unique_ptr<SimulatedCanForceSensor> node;
  std::unique_ptr<CanForceSensor> client;

  SensorBus() {
    const int host = bus.AddNode();
    const int n = bus.AddNode();
    const int m = bus.AddNode();
    host_port = bus.MakePort(host, CanForceSensor::ReceiveOptions(config));
    node_port = bus.MakePort(n, SimulatedCanForceSensor::ReceiveOptions());
    monitor = bus.MakePort(m, transport::CanReceiveOptions::Everything());
    sync = std::make_unique<canopen::SyncProducer>(*host_port);
    node = std::make_unique<SimulatedCanForceSensor>(config, *node_port);
    Timebase t;
    t.now_ns = [this] { return now_ns; };
    t.wait_ns = [this](std::uint64_t ns) { now_ns += ns; };
    client = std::make_unique<CanForceSensor>(config, *host_port, t);
  }
  /// One 1 ms cycle: SYNC, then bus time with the node answering.
  void Cycle() {
    ASSERT_EQ(sync->Send(), transport::CanWriteStatus::kOk);
    for (int k = 0; k < 10; ++k) {
      now_ns += 100'000;
      bus.Run();
      node->Step();
    }
  }
};

TEST(CanForceSensor, ReadsTheSimulatedNodeOnSyncAndGoesStaleWhenItFallsSilent) {
  SensorBus b;
  CanForceReading r;
  EXPECT_EQ(b.client->Read(r), CanForceSensorStatus::kStale);  // nothing yet: a fault, not zeros
  const std::array<double, 2> force{3.5, -20.25};
  b.node->SetForce(force);
  b.Cycle();
  ASSERT_EQ(b.client->Read(r), CanForceSensorStatus::kOk);
  EXPECT_TRUE(r.fresh);
  EXPECT_DOUBLE_EQ(r.force_N[0], 3.5);
  EXPECT_DOUBLE_EQ(r.force_N[1], -20.25);
  EXPECT_EQ(b.client->Read(r), CanForceSensorStatus::kNoNewData);
  // The bus carried SYNC, then the sensor's frame.
  CanFrame f;
  ASSERT_TRUE(b.monitor->Read(f));
  EXPECT_EQ(Hex(f), "080#");
  ASSERT_TRUE(b.monitor->Read(f));
  EXPECT_EQ(Hex(f), "190#5E0117F8");
  EXPECT_EQ(b.sync->counters().sent, 1u);

  b.node->SetSilent(true);
  int cycles = 0;
  CanForceSensorStatus s = CanForceSensorStatus::kOk;
  while (cycles < 50 && (s = b.client->Read(r)) != CanForceSensorStatus::kStale) {
    b.Cycle();
    ++cycles;
  }
  EXPECT_EQ(s, CanForceSensorStatus::kStale);
  EXPECT_GE(cycles, 9);  // stale_after_ms = 10 ms of 1 ms cycles, not before
  EXPECT_LE(cycles, 11);
  EXPECT_DOUBLE_EQ(r.force_N[1], -20.25);  // the last values stay visible, flagged stale
}

TEST(CanForceSensor, CountsAWrongLengthFrameAndAnInvalidValue) {
  SensorBus b;
  CanFrame wrong{};
  wrong.id = 0x190;
  wrong.len = 2;
  ASSERT_EQ(b.node_port->Write(wrong), transport::CanWriteStatus::kOk);
  const std::array<double, 2> force{NAN, 1.0};
  b.node->SetForce(force);
  b.Cycle();
  CanForceReading r;
  EXPECT_EQ(b.client->Read(r), CanForceSensorStatus::kOk);
  EXPECT_EQ(b.client->counters().rejected, 1u);
  EXPECT_EQ(b.client->counters().invalid_values, 1u);
  EXPECT_TRUE(std::isnan(r.force_N[0]));
}

TEST(SyncProducer, RefusesNmtAndExtendedIdentifiers) {
  transport::EmulatedCanBus bus{transport::EmulatedCanBusConfig{}};
  auto port = bus.MakePort(bus.AddNode());
  EXPECT_THROW(canopen::SyncProducer(*port, 0x000), Error);
  EXPECT_THROW(canopen::SyncProducer(*port, 0x800), Error);
  EXPECT_NO_THROW(canopen::SyncProducer(*port, 0x081));
}

}  // namespace
}  // namespace teleop::fieldbus
