// The device seam's bus exchange (teleop/device/bus_exchange.hpp) as the node drives it: once per cycle, before
// Read, on a device that has one; a faulted cycle exchanges too (the bus keeps its SYNC while the device is safe).
#include "teleop/device/bus_exchange.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "teleop/config/yaml_config.hpp"
#include "teleop/node/teleop_node.hpp"
#include "teleop/transport/emulated_link.hpp"
#include "test_utilities/temp_dir.hpp"

namespace teleop::node {
namespace {

/// A one-DOF device on a "bus": it logs every cycle call in order (the log is sized before the cycles run).
class ExchangingDevice final : public device::Device, public device::BusExchange {
 public:
  ExchangingDevice() { log.reserve(4096); }
  const device::Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override { return name_; }
  void Exchange() noexcept override { log.push_back('E'); }
  void Read(device::Reading& out) noexcept override {
    log.push_back('R');
    out.position_m = DofVector::Zero(1);
    out.velocity_m_per_s = DofVector::Zero(1);
    out.force_N = DofVector::Zero(1);
    out.rendered_force_N = DofVector::Zero(1);
    out.faults = faults;
  }
  void Write(const device::Command&) noexcept override { log.push_back('W'); }
  void Update(double) noexcept override { log.push_back('U'); }
  void SetSafe() noexcept override { log.push_back('S'); }

  std::string log;
  std::uint32_t faults = device::kFaultNone;

 private:
  device::Capabilities capabilities_{};
  std::string name_ = "exchanging";
};

std::string Config(const std::string& dir) {
  return R"(role: slave
dof: 1
rate_hz: 1000
link: {security: {mode: insecure}, bind: "127.0.0.1:47011", peer: "127.0.0.1:47012", timeout_ms: 100}
law: {kp_N_per_m: 600, kd_Ns_per_m: 0, max_force_N: 0}
device: {backend: loopback, loopback: {mass_kg: 0.04, damping_Ns_per_m: 0.41}}
stability: {check: false}
safety: {reaction: zero_force, fault_record_dir: ")" +
         dir + "\"}\n";
}

TEST(NodeBusExchange, OncePerCycleBeforeReadAlsoInTheSafeState) {
  test::ScopedTempDir dir("bus-exchange");
  auto owned = std::make_unique<ExchangingDevice>();
  ExchangingDevice& d = *owned;
  auto medium = std::make_shared<transport::EmulatedMedium>(transport::EmulatedMediumConfig{});
  TeleopNode node(config::ParseProcessConfig(Config(dir.path().string()), "slave.yaml"), std::move(owned),
                  std::make_unique<transport::EmulatedLink>(medium, proto::SenderRole::kSlave));
  d.log.clear();
  for (std::uint64_t k = 0; k < 3; ++k) node.Step(k, 1e-3, 1'000'000'000 + static_cast<std::int64_t>(k) * 1'000'000);
  EXPECT_EQ(d.log, "ERWUERWUERWU");
  d.log.clear();
  d.faults = device::kFaultCommunication;
  node.Step(3, 1e-3, 1'003'000'000);
  EXPECT_EQ(d.log, "ERSU") << "a faulted device still gets its exchange, then the safe state";
}

}  // namespace
}  // namespace teleop::node
