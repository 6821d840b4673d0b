// The `link.can` section: transports can / emulated-can, their keys, and the errors a user sees.
#include <gtest/gtest.h>

#include <string>

#include "teleop/config/yaml_config.hpp"
#include "teleop/error.hpp"

namespace teleop::config {
namespace {

std::string Config(const std::string& link) {
  return "role: slave\ndof: 3\nrate_hz: 1000\nlink:\n" + link + "  security: {mode: insecure}\n" +
         "law: {kp_N_per_m: 600, kd_Ns_per_m: 2}\n"
         "device: {backend: loopback, loopback: {mass_kg: 0.036, damping_Ns_per_m: 0.49}}\n";
}

std::string ErrorOf(const std::string& text) {
  try {
    (void)ParseProcessConfig(text, "can.yaml");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(CanLinkConfig, SocketCanSectionFillsTheLinkConfig) {
  const ProcessConfig c = ParseProcessConfig(Config("  transport: can\n  timeout_ms: 20\n"
                                                    "  can: {interface: vcan0, fd: true, nominal_bitrate_bit_per_s: "
                                                    "500000, data_bitrate_bit_per_s: 2000000, extended_id: true, "
                                                    "master_to_slave_base_id: 0x200, slave_to_master_base_id: 0x300, "
                                                    "max_bus_load: 0.5}\n"),
                                             "can.yaml");
  EXPECT_EQ(c.link.transport, "can");
  EXPECT_EQ(c.link.can.medium, transport::CanMedium::kSocketCan);
  EXPECT_EQ(c.link.can.interface_name, "vcan0");
  EXPECT_TRUE(c.link.can.fd);
  EXPECT_DOUBLE_EQ(c.link.can.nominal_bitrate_bit_per_s, 500000.0);
  EXPECT_DOUBLE_EQ(c.link.can.data_bitrate_bit_per_s, 2000000.0);
  EXPECT_TRUE(c.link.can.extended_id);
  EXPECT_EQ(c.link.can.master_to_slave_base_id, 0x200u);
  EXPECT_EQ(c.link.can.slave_to_master_base_id, 0x300u);
  EXPECT_DOUBLE_EQ(c.link.can.max_bus_load, 0.5);
  EXPECT_EQ(c.link.can.dof, 3);  // from the process, never configured twice
  EXPECT_DOUBLE_EQ(c.link.rate_hz, 1000.0);
  EXPECT_DOUBLE_EQ(c.link.timeout_ms, 20.0);
}

TEST(CanLinkConfig, EmulatedBusNeedsNoInterfaceAndTakesTheDaemonAddress) {
  const ProcessConfig c =
      ParseProcessConfig(Config("  transport: emulated-can\n  can: {bus: \"127.0.0.1:47400\"}\n"), "can.yaml");
  EXPECT_EQ(c.link.can.medium, transport::CanMedium::kEmulatedBus);
  EXPECT_EQ(c.link.can.emulated_bus_host, "127.0.0.1");
  EXPECT_EQ(c.link.can.emulated_bus_port, 47400);
  const ProcessConfig d = ParseProcessConfig(Config("  transport: emulated-can\n"), "can.yaml");
  EXPECT_EQ(d.link.can.emulated_bus_port, 47300);  // the documented default
}

// The Unix-domain form of the daemon's address (docs/security.md, "What CAN trusts"): kept whole as the host.
TEST(CanLinkConfig, EmulatedBusTakesAUnixSocketPath) {
  const ProcessConfig c = ParseProcessConfig(
      Config("  transport: emulated-can\n  can: {bus: \"unix:/run/teleop/canbus.sock\"}\n"), "can.yaml");
  EXPECT_EQ(c.link.can.emulated_bus_host, "unix:/run/teleop/canbus.sock");
  EXPECT_EQ(c.link.can.emulated_bus_port, 0);
  EXPECT_NE(ErrorOf(Config("  transport: emulated-can\n  can: {bus: \"unix:relative.sock\"}\n")).find("absolute path"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Config("  transport: emulated-can\n  can: {bus: \"unix:\"}\n")).find("link.can.bus"),
            std::string::npos);
}

// A triggered slave waits for the master's whole cycle of frames (docs/can.md, "Phase-locked cycles over CAN").
TEST(CanLinkConfig, TriggeredCyclesRunOverCan) {
  EXPECT_EQ(
      ParseProcessConfig(Config("  transport: emulated-can\n") + "sync: {mode: triggered}\n", "can.yaml").loop.sync,
      runtime::CycleSync::kTriggered);
  EXPECT_EQ(ParseProcessConfig(Config("  transport: can\n  can: {interface: vcan0}\n") + "sync: {mode: triggered}\n",
                               "can.yaml")
                .loop.sync,
            runtime::CycleSync::kTriggered);
  EXPECT_EQ(ParseProcessConfig(Config("  transport: emulated-can\n") + "sync: {mode: free}\n", "can.yaml").loop.sync,
            runtime::CycleSync::kFree);
}

TEST(CanLinkConfig, ErrorsNameFileLineAndKey) {
  EXPECT_NE(ErrorOf(Config("  transport: can\n")).find("can.yaml:5:3: key 'link.can'"), std::string::npos);
  EXPECT_NE(ErrorOf(Config("  transport: can\n  can: {fd: true}\n")).find("interface"), std::string::npos);
  EXPECT_NE(ErrorOf(Config("  transport: can\n  can: {interface: vcan0, speed: 5}\n")).find("speed"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Config("  transport: can\n  bind: \"127.0.0.1:1\"\n  can: {interface: vcan0}\n"))
                .find("only for transport udp"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Config("  transport: can\n  busy_poll_us: 50\n  can: {interface: vcan0}\n"))
                .find("key 'link.busy_poll_us': only for transport udp"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Config("  transport: can\n  can: {interface: vcan0, master_to_slave_base_id: 0x7FF}\n"))
                .find("master_to_slave_base_id"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Config("  transport: can\n  can: {interface: vcan0, master_to_slave_base_id: 0x100, "
                           "slave_to_master_base_id: 0x102}\n"))
                .find("at least 5 apart"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Config("  transport: can\n  can: {interface: vcan0, max_bus_load: 1.5}\n")).find("max_bus_load"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Config("  transport: udp\n  bind: \"127.0.0.1:1\"\n  peer: \"127.0.0.1:2\"\n"
                           "  can: {interface: vcan0}\n"))
                .find("only for transport can"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Config("  transport: carrier-pigeon\n")).find("known: udp, can, emulated-can"), std::string::npos);
}

}  // namespace
}  // namespace teleop::config
