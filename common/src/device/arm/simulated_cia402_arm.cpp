// The simulated arm on simulated CiA 402 drives (simulated_cia402_arm.hpp).

#include "simulated_cia402_arm.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "teleop/error.hpp"

namespace teleop::device::arm {

namespace {
constexpr std::uint64_t kBusStep_ns = 50'000;  // the drives serve their frames at least this often
}  // namespace

SimulatedCia402Arm::SimulatedCia402Arm(std::unique_ptr<SimulatedArm> arm, const Cia402JointBusConfig& config,
                                       int substeps)
    : arm_(std::move(arm)), config_(config), substeps_(std::max(1, substeps)) {
  if (arm_->joint_count() != static_cast<int>(config_.joints.size())) {
    throw Error("arm: cia402.joints has " + std::to_string(config_.joints.size()) + " drives, the chain has " +
                std::to_string(arm_->joint_count()) + " joints");
  }
  transport::EmulatedCanBusConfig b;
  b.nominal_bitrate_bit_per_s = config_.nominal_bitrate_bit_per_s;
  for (int i = 0; i < config_.bus_count(); ++i) {
    buses_.push_back(std::make_unique<transport::EmulatedCanBus>(b, [this] { return now_ns_; }));
    buses_.back()->SetSleeper([this](std::uint64_t until_ns) { StepBuses(until_ns); });
  }
  for (const Cia402JointConfig& j : config_.joints) {
    fieldbus::SimulatedCia402DriveConfig d;
    d.node_id = j.node_id;
    d.joint.external_shaft = true;
    d.joint.torque_lag_s = 2e-4;  // a drive's current loop: a few kHz
    d.rated_torque_mNm = static_cast<std::uint32_t>(std::lround(j.rated_torque_Nm * 1e3));
    d.position_rad_per_count = j.position_rad_per_count;
    d.velocity_rad_per_s_per_unit = j.velocity_rad_per_s_per_unit;
    transport::EmulatedCanBus& bus = *buses_[static_cast<std::size_t>(j.bus)];
    drive_ports_.push_back(bus.MakePort(bus.AddNode(), fieldbus::SimulatedCia402Drive::ReceiveOptions(d)));
    drives_.push_back(std::make_unique<fieldbus::SimulatedCia402Drive>(d, *drive_ports_.back()));
    drives_.back()->Step(0);
  }
  FollowArm();
}

SimulatedCia402Arm::~SimulatedCia402Arm() = default;

std::unique_ptr<transport::CanPort> SimulatedCia402Arm::MakeHostPort(int bus,
                                                                     const transport::CanReceiveOptions& options) {
  transport::EmulatedCanBus& b = *buses_.at(static_cast<std::size_t>(bus));
  return b.MakePort(b.AddNode(), options);
}

void SimulatedCia402Arm::FollowArm() noexcept {
  const JointVector& q = arm_->q();
  const JointVector& v = arm_->v();
  for (std::size_t i = 0; i < drives_.size(); ++i) {
    const Cia402JointConfig& j = config_.joints[i];
    const auto k = static_cast<Eigen::Index>(i);
    drives_[i]->SetJointState(j.sign * j.gear_ratio * (q[k] - j.offset_rad), j.sign * j.gear_ratio * v[k]);
  }
}

void SimulatedCia402Arm::StepBuses(std::uint64_t until_ns) noexcept {
  while (now_ns_ < until_ns) {
    now_ns_ = std::min(until_ns, now_ns_ + kBusStep_ns);
    for (auto& b : buses_) b->Run();
    for (auto& d : drives_) d->Step(now_ns_);
    for (auto& b : buses_) b->Run();
  }
}

void SimulatedCia402Arm::Advance(double period_s) noexcept {
  const std::uint64_t start = now_ns_;
  const auto period_ns = static_cast<std::uint64_t>(std::llround(period_s * 1e9));
  const double h = period_s / substeps_;
  for (int s = 0; s < substeps_; ++s) {
    StepBuses(start + period_ns * static_cast<std::uint64_t>(s + 1) / static_cast<std::uint64_t>(substeps_));
    for (std::size_t i = 0; i < drives_.size(); ++i) {
      const Cia402JointConfig& j = config_.joints[i];
      arm_->joint(static_cast<int>(i)).WriteTorque(j.sign * j.gear_ratio * drives_[i]->applied_torque_Nm());
    }
    arm_->Exchange(h);
    FollowArm();
  }
}

fieldbus::Timebase SimulatedCia402Arm::timebase() {
  fieldbus::Timebase t;
  t.now_ns = [this] { return now_ns_; };
  t.wait_ns = [this](std::uint64_t ns) { StepBuses(now_ns_ + ns); };
  return t;
}

}  // namespace teleop::device::arm
