#pragma once

#include <cstdint>

#include "teleop/device/device.hpp"
#include "teleop/node/engagement_config.hpp"

namespace teleop::node {

/// The node's own plausibility checks of a device reading, on top of the fault bits the backend reports: a
/// non-finite value, a position or force beyond the configured bound, an encoder jump beyond
/// max_speed · period + slack since the previous reading. Returns device::FaultBits (0: plausible).
/// Allocation-free, noexcept.
class ReadingCheck {
 public:
  ReadingCheck(const SafetyConfig& safety, const device::Capabilities& capabilities, int dof);

  std::uint32_t Check(const device::Reading& reading, double period_s) noexcept;

  std::uint64_t nonfinite() const noexcept { return nonfinite_; }
  std::uint64_t out_of_range() const noexcept { return out_of_range_; }
  std::uint64_t encoder_jumps() const noexcept { return encoder_jumps_; }

 private:
  SafetyConfig safety_;
  bool measures_velocity_;
  bool measures_force_;
  DofVector previous_m_;
  bool have_previous_ = false;
  std::uint64_t nonfinite_ = 0;
  std::uint64_t out_of_range_ = 0;
  std::uint64_t encoder_jumps_ = 0;
};

}  // namespace teleop::node
