// The SocketCAN port. Here (no AF_CAN in the kernel) it must fail at open with a message that says what to do; in
// the qemu guest (AF_CAN, CAN_IFACE=vcan0) the exchange test runs on a real kernel CAN stack.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "can_test_helpers.hpp"
#include "teleop/error.hpp"
#include "teleop/transport/can_link.hpp"
#include "teleop/transport/can_socket_port.hpp"

namespace teleop::transport {
namespace {

TEST(SocketCan, FailsClearlyWithoutAfCan) {
  if (AfCanAvailable()) GTEST_SKIP() << "this kernel has AF_CAN";
  proto::can::CanWireFormat format{};
  try {
    SocketCanPort port("vcan0", format, proto::SenderRole::kMaster);
    FAIL() << "opened a CAN socket on a kernel without AF_CAN";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("AF_CAN not supported by this kernel"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("emulated-can"), std::string::npos) << e.what();
  }
  CanLinkConfig config;
  config.dof = 3;
  config.interface_name = "vcan0";
  EXPECT_THROW((void)MakeCanLink(config, proto::SenderRole::kSlave, 1000.0), Error);
}

TEST(SocketCan, MissingInterfaceIsNamed) {
  if (!AfCanAvailable()) GTEST_SKIP() << "no AF_CAN in this kernel";
  try {
    SocketCanPort port("nocan7", proto::can::CanWireFormat{}, proto::SenderRole::kMaster);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no interface 'nocan7'"), std::string::npos) << e.what();
  }
}

// Runs where a SocketCAN interface exists (CAN_IFACE, e.g. vcan0 in the qemu guest): master and slave sockets on
// the same interface exchange 200 cycles, classic then FD (FD only when the interface MTU allows it).
TEST(SocketCan, ExchangesSamplesOnARealInterface) {
  const char* iface = std::getenv("CAN_IFACE");
  if (!AfCanAvailable() || iface == nullptr) GTEST_SKIP() << "needs AF_CAN and CAN_IFACE (run in the qemu guest)";
  for (const bool fd : {false, true}) {
    proto::can::CanWireFormat format{};
    format.dof = 3;
    format.fd = fd;
    std::unique_ptr<CanPort> master_port, slave_port;
    try {
      master_port = std::make_unique<SocketCanPort>(iface, format, proto::SenderRole::kMaster);
      slave_port = std::make_unique<SocketCanPort>(iface, format, proto::SenderRole::kSlave);
    } catch (const Error& e) {
      // CAN_EXPECT_FD=1 (the qemu guest switches vcan0 to MTU 72): an FD interface that cannot be opened is a
      // failure, not a skip.
      const char* expect_fd = std::getenv("CAN_EXPECT_FD");
      if (fd && (expect_fd == nullptr || std::string(expect_fd) != "1")) {
        std::printf("FD skipped: %s\n", e.what());
        continue;
      }
      FAIL() << (fd ? "fd" : "classic") << " SocketCAN port on " << iface << ": " << e.what();
    }
    CanLink master(format, proto::SenderRole::kMaster, std::move(master_port));
    CanLink slave(format, proto::SenderRole::kSlave, std::move(slave_port));
    proto::SampleMessage out{};
    int got = 0;
    for (std::uint32_t s = 0; s < 200; ++s) {
      ASSERT_TRUE(master.Send(test::MakeSample(proto::SenderRole::kMaster, 3, s)));
      for (int tries = 0; tries < 1000 && !slave.Poll(out); ++tries) {
      }
      if (out.sequence % 16 == s % 16 && test::ConsistentSample(out)) ++got;
    }
    EXPECT_EQ(got, 200) << (fd ? "fd" : "classic") << ": " << slave.Summary();
    EXPECT_EQ(slave.counters().rejected, 0u);
    std::printf("%s: %s\n", fd ? "fd" : "classic", slave.Summary().c_str());
  }
}

// The same filters a driver gives its port on the emulated bus, installed in the kernel (CAN_RAW_FILTER): only the
// matching identifiers of the matching width arrive; an inverted filter passes everything else.
TEST(SocketCan, ReceiveFiltersOnARealInterface) {
  const char* iface = std::getenv("CAN_IFACE");
  if (!AfCanAvailable() || iface == nullptr) GTEST_SKIP() << "needs AF_CAN and CAN_IFACE (run in the qemu guest)";
  CanReceiveOptions everything = CanReceiveOptions::Everything();
  everything.fd = false;
  SocketCanPort sender(iface, everything);
  CanReceiveOptions options;
  options.filters = {CanFilter::Exact(0x181), CanFilter::Masked(0x700, 0x780)};
  SocketCanPort driver(iface, options);
  CanReceiveOptions not_sync;
  CanFilter inverted = CanFilter::Exact(0x080);
  inverted.invert = true;
  not_sync.filters = {inverted};
  SocketCanPort monitor(iface, not_sync);
  const std::uint32_t ids[] = {0x080, 0x180, 0x181, 0x701, 0x601, 0x77F};
  for (const std::uint32_t id : ids) {
    proto::can::CanFrame f{};
    f.id = id;
    f.len = 1;
    ASSERT_EQ(sender.Write(f), CanWriteStatus::kOk);
  }
  proto::can::CanFrame ext{};
  ext.id = 0x181;
  ext.extended = true;
  ext.len = 1;
  ASSERT_EQ(sender.Write(ext), CanWriteStatus::kOk);
  auto read_all = [](CanPort& port, std::size_t want) {
    std::vector<std::uint32_t> got;
    proto::can::CanFrame f{};
    for (int tries = 0; tries < 20000 && got.size() < want; ++tries) {
      if (port.Read(f)) got.push_back(f.id | (f.extended ? CanFilter::kExtendedFlag : 0u));
    }
    for (int tries = 0; tries < 2000; ++tries) {  // and nothing more
      if (port.Read(f)) got.push_back(f.id | (f.extended ? CanFilter::kExtendedFlag : 0u));
    }
    return got;
  };
  EXPECT_EQ(read_all(driver, 3), (std::vector<std::uint32_t>{0x181, 0x701, 0x77F}));
  EXPECT_EQ(read_all(monitor, 6),
            (std::vector<std::uint32_t>{0x180, 0x181, 0x701, 0x601, 0x77F, 0x181 | CanFilter::kExtendedFlag}));
  std::printf("filters: %s, %s\n", driver.Describe().c_str(), monitor.Describe().c_str());
}

}  // namespace
}  // namespace teleop::transport
