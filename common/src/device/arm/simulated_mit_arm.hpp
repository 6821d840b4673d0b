#pragma once

// The simulated arm on simulated MIT motors (docs/arms.md, "MIT motors"): the simulated arm's rigid-body dynamics
// (simulated_arm.hpp) driven through one fieldbus::SimulatedMitMotor per joint, on an in-process emulated CAN bus
// (transport::EmulatedCanBus on this plant's clock), so the MitJointBus under test speaks the bytes real motors
// speak: the frames cross the emulated bus at its bit rates, each motor decodes its command, runs its own PD plus
// the feed-forward, clamps to its peak torque, and answers with a feedback frame.
//
// Advance(period_s), once per cycle after the host's exchange: the clock runs over the period in steps of at most
// 50 µs (the bus delivers what has finished, each motor serves what reached it); at each of the arm's `substeps`
// the motors' torques (at the shaft's state) drive the arm, τ_joint = sign·gear·τ_motor, and the shafts follow the
// arm, θ = sign·gear·(q − offset). Set-up waits (the host's register reads, enable, disable) advance the bus and the
// motors alone: the arm holds still meanwhile (as if braked; set-up takes milliseconds).

#include <cstdint>
#include <memory>
#include <vector>

#include "mit_joint_bus.hpp"
#include "simulated_arm.hpp"
#include "teleop/fieldbus/simulated_mit_motor.hpp"
#include "teleop/transport/can_emulated_bus.hpp"

namespace teleop::device::arm {

class SimulatedMitArm final : public MitPlant {
 public:
  /// `arm`: the dynamics (its config's substeps are this plant's). Throws teleop::Error when the joint counts differ.
  SimulatedMitArm(std::unique_ptr<SimulatedArm> arm, const MitJointBusConfig& config, int substeps);
  ~SimulatedMitArm() override;

  /// The host's port on the bus (MitJointBus::ReceiveOptions(config)). Once.
  std::unique_ptr<transport::CanPort> MakeHostPort();

  void Advance(double period_s) noexcept override;
  fieldbus::Timebase timebase() override;

  // Test access.
  SimulatedArm& arm() noexcept { return *arm_; }
  fieldbus::SimulatedMitMotor& motor(int i) noexcept { return *motors_[static_cast<std::size_t>(i)]; }
  transport::EmulatedCanBus& bus() noexcept { return bus_; }
  std::uint64_t now_ns() const noexcept { return now_ns_; }

 private:
  void StepBus(std::uint64_t until_ns) noexcept;
  void FollowArm() noexcept;

  std::uint64_t now_ns_ = 0;
  transport::EmulatedCanBus bus_;
  std::unique_ptr<SimulatedArm> arm_;
  MitJointBusConfig config_;
  int substeps_;
  int host_node_ = 0;
  std::vector<std::unique_ptr<transport::CanPort>> motor_ports_;
  std::vector<std::unique_ptr<fieldbus::SimulatedMitMotor>> motors_;
};

}  // namespace teleop::device::arm
