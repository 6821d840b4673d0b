// Receive filters with SocketCAN's semantics (transport::CanFilter, Accepts) and the in-process emulated bus's
// ports that apply them: what a driver's port on the emulated bus receives is what a SocketCAN socket with the
// same filters would.
#include "teleop/transport/can_filter.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "can_test_helpers.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/can_emulated_bus.hpp"

namespace teleop::transport {
namespace {

using proto::can::CanFrame;

CanFrame Data(std::uint32_t id, bool extended = false) {
  CanFrame f{};
  f.id = id;
  f.extended = extended;
  f.len = 1;
  return f;
}

TEST(CanFilter, MatchesAsSocketCan) {
  const CanFilter exact = CanFilter::Exact(0x181);
  EXPECT_EQ(exact.id, 0x181u);
  EXPECT_EQ(exact.mask, 0x7FFu | CanFilter::kExtendedFlag | CanFilter::kRemoteFlag);  // struct can_filter words
  EXPECT_TRUE(Matches(exact, Data(0x181)));
  EXPECT_FALSE(Matches(exact, Data(0x182)));
  EXPECT_FALSE(Matches(exact, Data(0x181, true)));  // same number, 29-bit: another identifier
  CanFrame rtr = Data(0x181);
  rtr.remote = true;
  EXPECT_FALSE(Matches(exact, rtr));
  const CanFilter heartbeats = CanFilter::Masked(0x700, 0x780);
  EXPECT_TRUE(Matches(heartbeats, Data(0x701)));
  EXPECT_TRUE(Matches(heartbeats, Data(0x77F)));
  EXPECT_FALSE(Matches(heartbeats, Data(0x681)));
  const CanFilter ext = CanFilter::Exact(0x1ABCDE0, true);
  EXPECT_TRUE(Matches(ext, Data(0x1ABCDE0, true)));
  EXPECT_FALSE(Matches(ext, Data(0x1ABCDE1, true)));
  CanFilter inverted = CanFilter::Exact(0x080);
  inverted.invert = true;
  EXPECT_FALSE(Matches(inverted, Data(0x080)));
  EXPECT_TRUE(Matches(inverted, Data(0x081)));
  EXPECT_TRUE(Matches(CanFilter::All(), Data(0x1FFFFFFF, true)));
  EXPECT_TRUE(Matches(CanFilter::All(), rtr));
  CanFrame error{};
  error.error = true;
  error.error_class = proto::can::kErrBusOff;
  EXPECT_FALSE(Matches(CanFilter::All(), error));  // error frames go by the error mask, never by filters
}

TEST(CanFilter, AcceptsByFiltersErrorMaskAndFd) {
  CanReceiveOptions o;
  o.filters = {CanFilter::Exact(0x181), CanFilter::Exact(0x281)};
  EXPECT_TRUE(Accepts(o, Data(0x181)));
  EXPECT_TRUE(Accepts(o, Data(0x281)));
  EXPECT_FALSE(Accepts(o, Data(0x381)));
  CanFrame fd = Data(0x181);
  fd.fd = true;
  EXPECT_FALSE(Accepts(o, fd));  // no CAN_RAW_FD_FRAMES: FD frames are not delivered
  o.fd = true;
  EXPECT_TRUE(Accepts(o, fd));
  CanFrame bus_off{};
  bus_off.error = true;
  bus_off.error_class = proto::can::kErrBusOff;
  CanFrame arbitration{};
  arbitration.error = true;
  arbitration.error_class = proto::can::kErrLostArbitration;
  EXPECT_TRUE(Accepts(o, bus_off));       // the default mask has bus-off
  EXPECT_FALSE(Accepts(o, arbitration));  // and not lost arbitration (it floods)
  o.error_mask = 0;
  EXPECT_FALSE(Accepts(o, bus_off));
  o.filters.clear();  // no filters: no data frames at all
  EXPECT_FALSE(Accepts(o, Data(0x181)));
  EXPECT_TRUE(Accepts(CanReceiveOptions::Everything(), arbitration));

  proto::can::CanWireFormat format{};
  format.dof = 3;
  const CanReceiveOptions link = LinkReceiveOptions(format, proto::SenderRole::kMaster);
  ASSERT_EQ(link.filters.size(), 5u);
  EXPECT_TRUE(Accepts(link, Data(0x180)));  // the slave's identifiers 0x180..0x184
  EXPECT_TRUE(Accepts(link, Data(0x184)));
  EXPECT_FALSE(Accepts(link, Data(0x185)));
  EXPECT_FALSE(Accepts(link, Data(0x100)));  // its own
}

TEST(CanFilter, EmulatedBusPortsFilterLikeSockets) {
  test::ManualClock clock;
  EmulatedCanBus bus(EmulatedCanBusConfig{}, [&] { return clock.now_ns; });
  const int a = bus.AddNode();
  const int b = bus.AddNode();
  const int c = bus.AddNode();
  auto sender = bus.MakePort(a);
  CanReceiveOptions options;
  options.filters = {CanFilter::Exact(0x181), CanFilter::Masked(0x700, 0x780)};
  auto driver = bus.MakePort(b, options);
  auto everything = bus.MakePort(c);
  for (const std::uint32_t id : {0x080u, 0x181u, 0x182u, 0x701u, 0x601u}) {
    ASSERT_EQ(sender->Write(Data(id)), CanWriteStatus::kOk);
  }
  CanFrame fd = Data(0x181);
  fd.fd = true;
  ASSERT_EQ(sender->Write(fd), CanWriteStatus::kOk);
  EXPECT_EQ(driver->Write(fd), CanWriteStatus::kError);  // a classic port cannot send FD
  bus.InjectErrors(1);
  ASSERT_EQ(sender->Write(Data(0x181)), CanWriteStatus::kOk);
  clock.now_ns += 10'000'000;
  std::vector<std::uint32_t> got;
  int errors = 0;
  CanFrame f{};
  while (driver->Read(f)) {
    if (f.error) {
      ++errors;
    } else {
      got.push_back(f.id);
    }
  }
  // Arbitration order (everything was queued at t = 0, behind 0x080 on the wire); the FD frame dropped.
  EXPECT_EQ(got, (std::vector<std::uint32_t>{0x181, 0x181, 0x701}));
  EXPECT_EQ(errors, 1);  // the destroyed transmission's error frame (protocol | bus error)
  int all = 0;
  while (everything->Read(f)) ++all;
  EXPECT_EQ(all, 5 + 1 + 1 + 1);  // 5 classic, the FD frame, the error frame, the retransmission
  EXPECT_NE(driver->Describe().find("2 filters"), std::string::npos) << driver->Describe();
  CanReceiveOptions too_many;
  too_many.filters.assign(kMaxCanFilters + 1, CanFilter::All());
  EXPECT_THROW((void)bus.MakePort(b, too_many), Error);
}

}  // namespace
}  // namespace teleop::transport
