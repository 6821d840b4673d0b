// The event log's device-fault line: the fault bits, and what the device says failed (Device::FaultText) when it
// names it, so the operator reads "joint 6 'joint6': coil over-temperature" and not only a bit word.

#include "teleop/node/event_log.hpp"

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <array>
#include <memory>
#include <sstream>
#include <string>

#include "teleop/device/device.hpp"

namespace teleop::node {
namespace {

/// A device that only names its fault.
class NamedFaultDevice final : public device::Device {
 public:
  explicit NamedFaultDevice(std::string text) : text_(std::move(text)) {}
  const device::Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override { return name_; }
  void Read(device::Reading& /*out*/) noexcept override {}
  void Write(const device::Command& /*command*/) noexcept override {}
  void Update(double /*period_s*/) noexcept override {}
  void SetSafe() noexcept override {}
  std::string FaultText() const override { return text_; }

 private:
  device::Capabilities capabilities_;
  std::string name_ = "named";
  std::string text_;
};

/// What the log says for one device-fault event (value 0x8: over-temperature) with `device` attached.
std::string LoggedLine(const device::Device* device) {
  auto log = std::make_shared<std::ostringstream>();
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(*log);
  spdlog::default_logger()->sinks().push_back(sink);
  {
    EventLog events(16);
    events.SetDevice(device);
    events.Push({Event::Kind::kDeviceFault, 42, static_cast<double>(device::kFaultOvertemperature)});
    events.Stop();
  }
  spdlog::default_logger()->sinks().pop_back();
  return log->str();
}

TEST(EventLog, ADeviceFaultLineSaysWhatTheDeviceNames) {
  const NamedFaultDevice named("joint 6 'joint6': coil over-temperature (code 0xC)");
  const std::string line = LoggedLine(&named);
  EXPECT_NE(line.find("cycle 42: device fault 0x8, safe state: joint 6 'joint6': coil over-temperature (code 0xC)"),
            std::string::npos)
      << line;
}

TEST(EventLog, ADeviceFaultLineWithoutANameGivesTheBits) {
  const NamedFaultDevice unnamed("");
  const std::array<const device::Device*, 2> devices{&unnamed, nullptr};
  for (const device::Device* device : devices) {
    const std::string line = LoggedLine(device);
    EXPECT_NE(line.find("cycle 42: device fault 0x8, safe state"), std::string::npos) << line;
    EXPECT_EQ(line.find("safe state:"), std::string::npos) << line;
  }
}

}  // namespace
}  // namespace teleop::node
