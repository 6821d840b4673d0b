#pragma once

// A test double of device::Device (after libfranka's mock robot): it records every call in order, in a fixed log
// (no allocation in the cycle), returns a position the test sets, reports the faults the test injects, keeps the
// last Command, and can be told to fail Configure or Activate.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "teleop/device/device.hpp"
#include "teleop/error.hpp"

namespace teleop::test {

class MockDevice final : public device::Device {
 public:
  enum class Call : std::uint8_t { kConfigure, kActivate, kDeactivate, kRead, kWrite, kUpdate, kSetSafe };
  static constexpr std::size_t kLogCapacity = 1 << 16;

  explicit MockDevice(int dof, device::Rendering rendering = device::Rendering::kActiveForce) {
    capabilities_.dof = dof;
    capabilities_.rendering = rendering;
    position_m = DofVector::Zero(dof);
    force_N = DofVector::Zero(dof);
    last_command = device::Command::Force(DofVector::Zero(dof));
    rendered_force_N_ = DofVector::Zero(dof);
  }

  // What the test controls.
  DofVector position_m;          ///< Returned by Read.
  DofVector force_N;             ///< Returned by Read as the force sensor.
  std::uint32_t faults = 0;      ///< Returned by Read.
  std::uint32_t warnings = 0;    ///< Returned by Read (device::WarningBits).
  std::string configure_error;   ///< Non-empty: Configure throws teleop::Error with it.
  std::string activate_error;    ///< Non-empty: Activate throws teleop::Error with it.
  int* deactivations = nullptr;  ///< When set, incremented by Deactivate (outlives the device, which the node owns).
  device::Capabilities& mutable_capabilities() noexcept { return capabilities_; }

  // What the test reads back.
  device::Command last_command;
  std::uint64_t writes = 0;
  std::uint64_t safe_calls = 0;
  double last_period_s = 0.0;

  const device::Capabilities& capabilities() const noexcept override { return capabilities_; }
  const std::string& name() const noexcept override { return name_; }

  void Configure() override {
    Log(Call::kConfigure);
    if (!configure_error.empty()) throw Error(configure_error);
  }
  void Activate() override {
    Log(Call::kActivate);
    if (!activate_error.empty()) throw Error(activate_error);
  }
  void Deactivate() noexcept override {
    Log(Call::kDeactivate);
    if (deactivations != nullptr) ++*deactivations;
  }

  void Read(device::Reading& out) noexcept override {
    Log(Call::kRead);
    out.position_m = position_m;
    out.velocity_m_per_s = DofVector::Zero(position_m.size());
    out.force_N = force_N;
    out.rendered_force_N = rendered_force_N_;
    out.faults = faults;
    out.warnings = warnings;
  }
  void Write(const device::Command& command) noexcept override {
    Log(Call::kWrite);
    last_command = command;
    rendered_force_N_ = command.force_N;
    ++writes;
  }
  void Update(double period_s) noexcept override {
    Log(Call::kUpdate);
    last_period_s = period_s;
  }
  void SetSafe() noexcept override {
    Log(Call::kSetSafe);
    rendered_force_N_.setZero();
    ++safe_calls;
  }

  std::size_t calls() const noexcept { return count_; }
  Call call(std::size_t i) const noexcept { return log_[i % kLogCapacity]; }
  void ClearLog() noexcept { count_ = 0; }

 private:
  void Log(Call c) noexcept {
    log_[count_ % kLogCapacity] = c;
    ++count_;
  }

  device::Capabilities capabilities_{};
  std::string name_ = "mock";
  DofVector rendered_force_N_;
  std::array<Call, kLogCapacity> log_{};
  std::size_t count_ = 0;
};

}  // namespace teleop::test
