#include "teleop/fieldbus/simulated_can_force_sensor.hpp"

namespace teleop::fieldbus {

SimulatedCanForceSensor::SimulatedCanForceSensor(const CanForceSensorConfig& config, transport::CanPort& port,
                                                 bool on_sync, std::uint32_t sync_cob_id)
    : config_(config), port_(port), on_sync_(on_sync), sync_cob_id_(sync_cob_id) {
  config_.Validate("simulated force sensor");
}

transport::CanReceiveOptions SimulatedCanForceSensor::ReceiveOptions(std::uint32_t sync_cob_id) {
  transport::CanReceiveOptions o;
  o.filters = {transport::CanFilter::Exact(sync_cob_id)};
  o.error_mask = 0;
  return o;
}

void SimulatedCanForceSensor::SetForce(std::span<const double> force_N) noexcept {
  for (std::size_t a = 0; a < force_N.size() && a < force_N_.size(); ++a) force_N_[a] = force_N[a];
}

void SimulatedCanForceSensor::Send() noexcept {
  if (silent_) return;
  canopen::CanFrame frame;
  if (EncodeForceFrame(config_, force_N_, frame) && port_.Write(frame) == transport::CanWriteStatus::kOk) {
    ++frames_sent_;
  }
}

void SimulatedCanForceSensor::Step() noexcept {
  if (!on_sync_) {
    Send();
    return;
  }
  canopen::CanFrame frame;
  while (port_.Read(frame)) {
    if (!frame.error && !frame.extended && frame.id == sync_cob_id_) Send();
  }
}

}  // namespace teleop::fieldbus
