// The simulated arm on simulated MIT motors (simulated_mit_arm.hpp).

#include "simulated_mit_arm.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::device::arm {

namespace {
constexpr std::uint64_t kBusStep_ns = 50'000;  // the motors serve their frames at least this often

transport::EmulatedCanBusConfig BusConfig(const MitJointBusConfig& config) {
  transport::EmulatedCanBusConfig b;
  b.nominal_bitrate_bit_per_s = config.nominal_bitrate_bit_per_s;
  b.data_bitrate_bit_per_s = config.data_bitrate_bit_per_s;
  return b;
}
}  // namespace

SimulatedMitArm::SimulatedMitArm(std::unique_ptr<SimulatedArm> arm, const MitJointBusConfig& config, int substeps)
    : bus_(BusConfig(config), [this] { return now_ns_; }),
      arm_(std::move(arm)),
      config_(config),
      substeps_(std::max(1, substeps)) {
  if (arm_->joint_count() != static_cast<int>(config_.joints.size())) {
    throw Error("arm: mit.joints has " + std::to_string(config_.joints.size()) + " motors, the chain has " +
                std::to_string(arm_->joint_count()) + " joints");
  }
  bus_.SetSleeper([this](std::uint64_t until_ns) { StepBus(until_ns); });
  host_node_ = bus_.AddNode();
  for (const MitJointConfig& j : config_.joints) {
    fieldbus::SimulatedMitMotorConfig m;
    m.esc_id = j.esc_id;
    m.master_id = j.master_id;
    m.ranges = j.motor.ranges;
    m.peak_torque_Nm = j.motor.peak_torque_Nm;
    m.external_shaft = true;
    const int node = bus_.AddNode();
    motor_ports_.push_back(bus_.MakePort(node, fieldbus::SimulatedMitMotor::ReceiveOptions(m)));
    motors_.push_back(std::make_unique<fieldbus::SimulatedMitMotor>(m, *motor_ports_.back()));
    motors_.back()->Step(0);
  }
  FollowArm();
}

SimulatedMitArm::~SimulatedMitArm() = default;

std::unique_ptr<transport::CanPort> SimulatedMitArm::MakeHostPort() {
  return bus_.MakePort(host_node_, MitJointBus::ReceiveOptions(config_));
}

void SimulatedMitArm::FollowArm() noexcept {
  const JointVector& q = arm_->q();
  const JointVector& v = arm_->v();
  for (std::size_t i = 0; i < motors_.size(); ++i) {
    const MitJointConfig& j = config_.joints[i];
    const auto k = static_cast<Eigen::Index>(i);
    motors_[i]->SetShaft(j.sign * j.gear_ratio * (q[k] - j.offset_rad), j.sign * j.gear_ratio * v[k]);
  }
}

void SimulatedMitArm::StepBus(std::uint64_t until_ns) noexcept {
  while (now_ns_ < until_ns) {
    now_ns_ = std::min(until_ns, now_ns_ + kBusStep_ns);
    bus_.Run();
    for (auto& m : motors_) m->Step(static_cast<std::int64_t>(now_ns_));
    bus_.Run();
  }
}

void SimulatedMitArm::Advance(double period_s) noexcept {
  const std::uint64_t start = now_ns_;
  const auto period_ns = static_cast<std::uint64_t>(std::llround(period_s * 1e9));
  const double h = period_s / substeps_;
  for (int s = 0; s < substeps_; ++s) {
    StepBus(start + period_ns * static_cast<std::uint64_t>(s + 1) / static_cast<std::uint64_t>(substeps_));
    for (std::size_t i = 0; i < motors_.size(); ++i) {
      const MitJointConfig& j = config_.joints[i];
      arm_->joint(static_cast<int>(i)).WriteTorque(j.sign * j.gear_ratio * motors_[i]->OutputTorque());
    }
    arm_->Exchange(h);
    FollowArm();
  }
}

fieldbus::Timebase SimulatedMitArm::timebase() {
  fieldbus::Timebase t;
  t.now_ns = [this] { return now_ns_; };
  t.wait_ns = [this](std::uint64_t ns) { StepBus(now_ns_ + ns); };
  return t;
}

}  // namespace teleop::device::arm
