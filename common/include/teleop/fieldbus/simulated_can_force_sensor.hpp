#pragma once

// A simulated force sensor node (tests, the emulated rig): sends the configured frame with the values it is given,
// on every SYNC it reads (transmission type 1) or on every Step when `on_sync` is false. Same bytes as
// CanForceSensor decodes (EncodeForceFrame). Fault injection: silence.

#include <array>
#include <cstdint>

#include "teleop/fieldbus/can_force_sensor.hpp"

namespace teleop::fieldbus {

class SimulatedCanForceSensor {
 public:
  /// `port` must outlive it and should receive ReceiveOptions(sync_cob_id) when on_sync.
  SimulatedCanForceSensor(const CanForceSensorConfig& config, transport::CanPort& port, bool on_sync = true,
                          std::uint32_t sync_cob_id = canopen::cob::kSync);

  static transport::CanReceiveOptions ReceiveOptions(std::uint32_t sync_cob_id = canopen::cob::kSync);

  /// The values the next frames carry (SI; NaN sends the invalid value).
  void SetForce(std::span<const double> force_N) noexcept;
  /// Drains the port; sends one frame per SYNC read (on_sync) or one frame now. No allocation.
  void Step() noexcept;
  void SetSilent(bool silent) noexcept { silent_ = silent; }
  std::uint64_t frames_sent() const noexcept { return frames_sent_; }

 private:
  void Send() noexcept;
  CanForceSensorConfig config_;
  transport::CanPort& port_;
  bool on_sync_;
  std::uint32_t sync_cob_id_;
  std::array<double, kMaxForceSensorAxes> force_N_{};
  bool silent_ = false;
  std::uint64_t frames_sent_ = 0;
};

}  // namespace teleop::fieldbus
