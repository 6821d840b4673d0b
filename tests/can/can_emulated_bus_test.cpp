// The emulated CAN bus: arbitration order, frame-time pacing, the load ceiling, error frames, fault confinement
// up to bus-off, queue limits.
#include "teleop/transport/can_emulated_bus.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "can_test_helpers.hpp"
#include "teleop/error.hpp"

namespace teleop::transport {
namespace {

using proto::can::CanFrame;

CanFrame Frame(std::uint32_t id, std::uint8_t len = 8, bool extended = false) {
  CanFrame f{};
  f.id = id;
  f.len = len;
  f.extended = extended;
  f.data[0] = static_cast<std::uint8_t>(id);
  return f;
}

struct Bus {
  test::ManualClock clock;
  EmulatedCanBus bus;
  int a, b, c;
  explicit Bus(EmulatedCanBusConfig config = {})
      : bus(config, [this] { return clock.now_ns; }), a(bus.AddNode()), b(bus.AddNode()), c(bus.AddNode()) {}
  std::vector<CanFrame> Drain(int node) {
    std::vector<CanFrame> out;
    CanFrame f{};
    while (bus.Receive(node, f)) out.push_back(f);
    return out;
  }
};

constexpr std::uint64_t kFrame8_ns = 135'000;  // 55 + 10·8 bits at 1 Mbit/s

TEST(EmulatedCanBus, DeliversInIdOrderAtFrameTime) {
  Bus t;
  ASSERT_EQ(t.bus.Submit(t.a, Frame(0x300)), CanWriteStatus::kOk);  // on the wire at once
  ASSERT_EQ(t.bus.Submit(t.b, Frame(0x180)), CanWriteStatus::kOk);  // the rest wait for arbitration
  ASSERT_EQ(t.bus.Submit(t.a, Frame(0x101)), CanWriteStatus::kOk);
  ASSERT_EQ(t.bus.Submit(t.a, Frame(0x100)), CanWriteStatus::kOk);
  t.clock.now_ns = kFrame8_ns - 1;
  EXPECT_TRUE(t.Drain(t.c).empty());
  const std::vector<std::uint32_t> expected{0x300, 0x100, 0x101, 0x180};
  for (std::size_t i = 0; i < expected.size(); ++i) {
    t.clock.now_ns = (i + 1) * kFrame8_ns;
    const auto got = t.Drain(t.c);
    ASSERT_EQ(got.size(), 1u) << "at " << t.clock.now_ns << " ns";
    EXPECT_EQ(got[0].id, expected[i]);
  }
  // The sender never reads its own frames; the other node reads the other's.
  const auto at_a = t.Drain(t.a);
  ASSERT_EQ(at_a.size(), 1u);
  EXPECT_EQ(at_a[0].id, 0x180u);
  EXPECT_EQ(t.bus.stats().frames_delivered, 4u);
  EXPECT_EQ(t.bus.stats().busy_ns, 4 * kFrame8_ns);
}

TEST(EmulatedCanBus, StandardBeatsExtendedWithSameBaseId) {
  Bus t;
  ASSERT_EQ(t.bus.Submit(t.a, Frame(0x300)), CanWriteStatus::kOk);
  ASSERT_EQ(t.bus.Submit(t.a, Frame(0x100u << 18, 8, true)), CanWriteStatus::kOk);
  ASSERT_EQ(t.bus.Submit(t.b, Frame(0x100)), CanWriteStatus::kOk);
  t.clock.now_ns = 1'000'000;
  const auto got = t.Drain(t.c);
  ASSERT_EQ(got.size(), 3u);
  EXPECT_FALSE(got[1].extended);
  EXPECT_TRUE(got[2].extended);
}

TEST(EmulatedCanBus, LoadCeilingStretchesFrameTime) {
  EmulatedCanBusConfig config;
  config.load_ceiling = 0.5;
  Bus t(config);
  ASSERT_EQ(t.bus.Submit(t.a, Frame(0x100, 6)), CanWriteStatus::kOk);  // 115 bits
  t.clock.now_ns = 2 * 115'000 - 1;
  EXPECT_TRUE(t.Drain(t.b).empty());
  t.clock.now_ns = 2 * 115'000;
  EXPECT_EQ(t.Drain(t.b).size(), 1u);
}

TEST(EmulatedCanBus, FdFrameTimeWithBitRateSwitch) {
  Bus t;
  CanFrame f = Frame(0x104, 16);
  f.fd = true;
  f.brs = true;
  ASSERT_EQ(t.bus.Submit(t.a, f), CanWriteStatus::kOk);
  const std::uint64_t end_ns = 34'000 + 38'600;  // 34 nominal bits at 1 Mbit/s + 193 data bits at 5 Mbit/s
  t.clock.now_ns = end_ns - 1;
  EXPECT_TRUE(t.Drain(t.b).empty());
  t.clock.now_ns = end_ns;
  EXPECT_EQ(t.Drain(t.b).size(), 1u);
}

TEST(EmulatedCanBus, InjectedErrorDestroysOneTransmissionWhichIsRetried) {
  Bus t;
  t.bus.InjectErrors(1);
  ASSERT_EQ(t.bus.Submit(t.a, Frame(0x100)), CanWriteStatus::kOk);
  t.clock.now_ns = kFrame8_ns + 23'000;  // destroyed frame + error frame (23 bits)
  auto got = t.Drain(t.b);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_TRUE(got[0].error);
  EXPECT_EQ(got[0].error_class, proto::can::kErrProtocol | proto::can::kErrBusError);
  EXPECT_EQ(t.bus.transmit_error_counter(t.a), 8);
  t.clock.now_ns += kFrame8_ns;
  got = t.Drain(t.b);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_FALSE(got[0].error);
  EXPECT_EQ(got[0].id, 0x100u);
  EXPECT_EQ(t.bus.transmit_error_counter(t.a), 7);
  EXPECT_EQ(t.bus.stats().error_frames, 1u);
}

TEST(EmulatedCanBus, RepeatedErrorsDriveTheSenderBusOff) {
  Bus t;
  t.bus.InjectErrors(100);
  ASSERT_EQ(t.bus.Submit(t.a, Frame(0x100)), CanWriteStatus::kOk);
  t.clock.now_ns = 100'000'000;
  t.bus.Run();  // the bus advances when used
  EXPECT_TRUE(t.bus.is_bus_off(t.a));
  EXPECT_EQ(t.bus.stats().error_frames, 32u);  // 32 × (TEC += 8) = 256
  bool warning = false, passive = false, bus_off = false;
  for (const CanFrame& f : t.Drain(t.a)) {
    ASSERT_TRUE(f.error);
    warning |= (f.error_class & proto::can::kErrController) != 0 && f.data[1] == proto::can::kCtrlTxWarning;
    passive |= (f.error_class & proto::can::kErrController) != 0 && f.data[1] == proto::can::kCtrlTxPassive;
    bus_off |= (f.error_class & proto::can::kErrBusOff) != 0;
  }
  EXPECT_TRUE(warning);
  EXPECT_TRUE(passive);
  EXPECT_TRUE(bus_off);
  EXPECT_EQ(t.bus.Submit(t.a, Frame(0x100)), CanWriteStatus::kBusOff);
  t.bus.Restart(t.a);
  t.bus.InjectErrors(-1000);  // no-op
  const auto restarted = t.Drain(t.a);
  ASSERT_EQ(restarted.size(), 1u);
  EXPECT_EQ(restarted[0].error_class, proto::can::kErrRestarted);
}

TEST(EmulatedCanBus, ForcedBusOffAndFullQueueRefuseFrames) {
  EmulatedCanBusConfig config;
  config.tx_queue_frames = 2;
  Bus t(config);
  EXPECT_EQ(t.bus.Submit(t.a, Frame(0x100)), CanWriteStatus::kOk);  // on the wire
  EXPECT_EQ(t.bus.Submit(t.a, Frame(0x101)), CanWriteStatus::kOk);
  EXPECT_EQ(t.bus.Submit(t.a, Frame(0x102)), CanWriteStatus::kBufferFull);  // 0x100 still in its queue until sent
  t.bus.ForceBusOff(t.b);
  EXPECT_EQ(t.bus.Submit(t.b, Frame(0x200)), CanWriteStatus::kBusOff);
  EXPECT_EQ(t.bus.stats().tx_refused, 2u);
  CanFrame bad = Frame(0x100, 9);
  EXPECT_EQ(t.bus.Submit(t.a, bad), CanWriteStatus::kError);
  EXPECT_THROW(EmulatedCanBus(EmulatedCanBusConfig{1e6, 5e6, 1.5, 8, 8}), Error);
}

}  // namespace
}  // namespace teleop::transport
