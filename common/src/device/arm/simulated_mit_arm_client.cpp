// The simulated MIT arm as a client of a shared CAN bus (simulated_mit_arm_client.hpp).

#include "simulated_mit_arm_client.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <string>
#include <utility>

#include "teleop/error.hpp"
#include "teleop/fieldbus/can_port_config.hpp"

namespace teleop::device::arm {

/// One motor's view of the shared port: the frames the client dispatched to it, in order (a fixed ring: a full ring
/// drops the newest, as a controller's receive FIFO does), and writes straight to the bus.
class SimulatedMitArmClient::MotorPort final : public transport::CanPort {
 public:
  explicit MotorPort(transport::CanPort& bus) : bus_(bus) {}
  transport::CanWriteStatus Write(const proto::can::CanFrame& frame) noexcept override { return bus_.Write(frame); }
  bool Read(proto::can::CanFrame& frame) noexcept override {
    if (count_ == 0) return false;
    frame = ring_[head_];
    head_ = (head_ + 1) % ring_.size();
    --count_;
    return true;
  }
  std::string Describe() const override { return bus_.Describe(); }
  std::int64_t now_ns() const noexcept override { return bus_.now_ns(); }
  void Push(const proto::can::CanFrame& frame) noexcept {
    if (count_ == ring_.size()) return;
    ring_[(head_ + count_) % ring_.size()] = frame;
    ++count_;
  }

 private:
  transport::CanPort& bus_;
  std::array<proto::can::CanFrame, 64> ring_{};
  std::size_t head_ = 0;
  std::size_t count_ = 0;
};

SimulatedMitArmClient::SimulatedMitArmClient(const ArmSection& section, double max_step_s)
    : config_(section.mit), max_step_s_(max_step_s) {
  if (!section.mit_actuators || section.mit.simulated) {
    throw Error(
        "simulated MIT motors on a bus: the config's device.arm needs actuators: mit with mit.bus: can (the bus "
        "the host process uses too); mit.bus: simulated runs its motors inside the host process already");
  }
  if (!(max_step_s > 0.0)) throw Error("simulated MIT motors on a bus: max_step_s must be > 0");
  ArmSection plant = section;
  plant.simulation.substeps = 1;  // Step integrates in its own steps
  arm_ = MakeSimulatedArm(plant);
  if (arm_->joint_count() != static_cast<int>(config_.joints.size())) {
    throw Error(fmt::format("device.arm.mit.joints has {} motors, the chain has {} joints", config_.joints.size(),
                            arm_->joint_count()));
  }
  transport::CanReceiveOptions options;
  options.filters.push_back(transport::CanFilter::Exact(proto::can::mit::kParameterId));
  for (const MitJointConfig& j : config_.joints) options.filters.push_back(transport::CanFilter::Exact(j.esc_id));
  options.error_mask = 0;
  options.fd = true;
  try {
    port_ = fieldbus::OpenCanPort(config_.can, options);
  } catch (const Error& e) {
    throw Error(fmt::format("simulated MIT motors of device.arm.mit: their bus: {}", e.what()));
  }
  for (const MitJointConfig& j : config_.joints) {
    fieldbus::SimulatedMitMotorConfig m;
    m.esc_id = j.esc_id;
    m.master_id = j.master_id;
    m.ranges = j.motor.ranges;
    m.peak_torque_Nm = j.motor.peak_torque_Nm;
    m.external_shaft = true;
    motor_ports_.push_back(std::make_unique<MotorPort>(*port_));
    motors_.push_back(std::make_unique<fieldbus::SimulatedMitMotor>(m, *motor_ports_.back()));
  }
  FollowArm();
}

SimulatedMitArmClient::~SimulatedMitArmClient() = default;

void SimulatedMitArmClient::FollowArm() noexcept {
  const JointVector& q = arm_->q();
  const JointVector& v = arm_->v();
  for (std::size_t i = 0; i < motors_.size(); ++i) {
    const MitJointConfig& j = config_.joints[i];
    const auto k = static_cast<Eigen::Index>(i);
    motors_[i]->SetShaft(j.sign * j.gear_ratio * (q[k] - j.offset_rad), j.sign * j.gear_ratio * v[k]);
  }
}

void SimulatedMitArmClient::Step(std::int64_t now_ns) noexcept {
  if (last_ns_ < 0) last_ns_ = now_ns;
  double left_s = static_cast<double>(now_ns - last_ns_) * 1e-9;
  last_ns_ = now_ns;
  if (!released_) {
    // On its stand until the host first enables a motor (its set-up, Configure and Activate, may take a while): these
    // motors have no brakes, and an arm falling while its host is still reading registers would start anywhere.
    for (const auto& m : motors_) released_ = released_ || m->enabled();
    if (!released_) left_s = 0.0;
  }
  while (left_s > 0.0) {
    const double h = std::min(left_s, max_step_s_);
    left_s -= h;
    for (std::size_t i = 0; i < motors_.size(); ++i) {
      const MitJointConfig& j = config_.joints[i];
      arm_->joint(static_cast<int>(i)).WriteTorque(j.sign * j.gear_ratio * motors_[i]->OutputTorque());
    }
    arm_->Exchange(h);
    FollowArm();
  }
  // The frames that reached the bus port, each to the motor of its id (a parameter request to every motor: each
  // answers only its own ESC_ID), then every motor serves them.
  proto::can::CanFrame frame;
  while (port_->Read(frame)) {
    for (std::size_t i = 0; i < motors_.size(); ++i) {
      if (frame.id == proto::can::mit::kParameterId || frame.id == config_.joints[i].esc_id)
        motor_ports_[i]->Push(frame);
    }
  }
  for (auto& m : motors_) m->Step(now_ns);
}

}  // namespace teleop::device::arm
